// JSON input with a nesting bound (json_io.h). The document is built by a SAX handler of our own, which checks
// every array or object start before it builds it: the parse stops at the first container too deep, so no value
// deeper than kMaxJsonDepth ever exists. It appends an object's members in file order without looking each key up
// among the members before it (nlohmann's own builder does, which made a parse quadratic in an object's keys): a
// set per open object refuses duplicate keys instead.
#include "host/io/json_io.h"

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "host/io/error.h"
#include "host/io/files.h"
#include "host/io/limits.h"

namespace rtu::host {
namespace {

using Json = nlohmann::ordered_json;

// nlohmann's messages start with a tag, "[json.exception.parse_error.101] parse error at ..."; drop it.
std::string without_tag(const std::string& what) {
  const size_t tag_end = what.find("] ");
  return tag_end == std::string::npos ? what : what.substr(tag_end + 2);
}

// Builds the document from nlohmann's SAX events (the interface of nlohmann::json_sax), keeping per open array or
// object the key path for messages and, for an object, the keys seen.
class Builder {
 public:
  Builder(Json& root, const std::string& what) : m_root(root), m_what(what) {}

  bool null() { return scalar(nullptr); }
  bool boolean(bool v) { return scalar(v); }
  bool number_integer(Json::number_integer_t v) { return scalar(v); }
  bool number_unsigned(Json::number_unsigned_t v) { return scalar(v); }
  bool number_float(Json::number_float_t v, const std::string&) { return scalar(v); }
  bool string(std::string& v) { return scalar(std::move(v)); }
  bool binary(Json::binary_t& v) { return scalar(std::move(v)); }
  bool start_object(size_t) { return open(true, Json::value_t::object); }
  bool start_array(size_t) { return open(false, Json::value_t::array); }
  bool end_object() { return close(); }
  bool end_array() { return close(); }

  bool key(std::string& k) {
    Frame& top = m_frames.back();
    top.key = k;
    if (!top.keys.insert(k).second) throw Error(m_what + ": duplicate key '" + path() + "'");
    // The key is new: appended to the members as it is, in file order (ordered_map is a vector of pairs).
    auto& members = static_cast<Json::object_t::Container&>(top.value->get_ref<Json::object_t&>());
    members.emplace_back(std::move(k), nullptr);
    m_member = &members.back().second;
    return true;
  }

  template <class Exception>
  bool parse_error(size_t, const std::string&, const Exception& e) {
    throw e;  // a parse_error, or out_of_range for a number beyond double range
  }

  // "meshes[2].transform"; past 8 levels the rest is elided: at the depth limit the full path would be a line of
  // 64 "[0]"s that says nothing more than the depth does.
  std::string path() const {
    constexpr size_t kShown = 8;
    std::string p;
    for (size_t i = 0; i < m_frames.size() && i < kShown; ++i) {
      const Frame& f = m_frames[i];
      p = f.object ? (p.empty() ? f.key : p + "." + f.key) : p + "[" + std::to_string(f.index) + "]";
    }
    if (m_frames.size() > kShown) p += "...";
    return p;
  }

 private:
  struct Frame {
    Json* value;
    bool object;
    std::string key;   // object: current key
    size_t index = 0;  // array: current element
    std::set<std::string> keys;
  };

  // Where the next value goes: the root, the array's next element, or the member its key appended.
  template <class V>
  Json* place(V&& v) {
    if (m_frames.empty()) {
      m_root = Json(std::forward<V>(v));
      return &m_root;
    }
    Frame& top = m_frames.back();
    if (top.object) {
      *m_member = Json(std::forward<V>(v));
      return m_member;
    }
    auto& elements = top.value->get_ref<Json::array_t&>();
    elements.emplace_back(std::forward<V>(v));
    return &elements.back();
  }
  template <class V>
  bool scalar(V&& v) {
    place(std::forward<V>(v));
    element_done();
    return true;
  }
  bool open(bool object, Json::value_t type) {
    if (m_frames.size() >= kMaxJsonDepth) {
      const std::string p = path();
      throw Error(m_what + ": " + (p.empty() ? "" : p + ": ") + "nested deeper than " +
                  std::to_string(kMaxJsonDepth) + " levels of arrays and objects (the limit for JSON input)");
    }
    Json* value = place(type);
    m_frames.push_back({value, object, "", 0, {}});
    return true;
  }
  bool close() {
    m_frames.pop_back();
    element_done();
    return true;
  }
  void element_done() {
    if (!m_frames.empty() && !m_frames.back().object) ++m_frames.back().index;
  }

  Json& m_root;
  const std::string& m_what;
  std::vector<Frame> m_frames;
  Json* m_member = nullptr;  // the value of the object member whose key came last
};

}  // namespace

Json parse_json_limited(const std::string& text, const std::string& what) {
  Json root;
  Builder b(root, what);
  try {
    Json::sax_parse(text, &b, Json::input_format_t::json, /*strict=*/true, /*ignore_comments=*/true);
  } catch (const Json::parse_error& e) {
    std::string message = without_tag(e.what());
    if (message.rfind("parse error", 0) != 0) message = "parse error: " + message;
    throw Error(what + ": " + message);
  } catch (const Json::out_of_range& e) {
    // A number beyond double range, e.g. 1e999: the path still points at it.
    const std::string p = b.path();
    throw Error(what + ": " + (p.empty() ? "" : p + ": ") + without_tag(e.what()) +
                " (not a finite number: NaN/Inf)");
  }
  return root;
}

Json read_json_file(const std::string& path) {
  check_input_file(path);
  std::error_code ec;
  // A floor of the peak: the text is held while its values are built (which take more again).
  const uint64_t bytes = std::filesystem::file_size(path, ec);
  if (!ec) check_memory(path + ": reading a " + std::to_string(bytes >> 20) + " MiB JSON file", bytes);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot read the file");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw Error(path + ": cannot read the file");
  return parse_json_limited(text, path);
}

}  // namespace rtu::host

// JSON input with a nesting bound (json_io.h). The bound is enforced by nlohmann's parser callback, which runs
// on every array or object start before the parser builds it: the parse stops at the first container too deep,
// so no value deeper than kMaxJsonDepth ever exists.
#include "host/io/json_io.h"

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
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

}  // namespace

Json parse_json_limited(const std::string& text, const std::string& what) {
  // One frame per open array or object: the key path for messages, and the keys seen (for duplicates).
  struct Frame {
    bool object;
    std::string key;   // object: current key
    size_t index = 0;  // array: current element
    std::set<std::string> keys;
  };
  std::vector<Frame> frames;
  auto element_done = [&] {
    if (!frames.empty() && !frames.back().object) ++frames.back().index;
  };
  // "meshes[2].transform"; past 8 levels the rest is elided: at the depth limit the full path would be a line of
  // 64 "[0]"s that says nothing more than the depth does.
  auto current_path = [&] {
    constexpr size_t kShown = 8;
    std::string path;
    for (size_t i = 0; i < frames.size() && i < kShown; ++i) {
      const Frame& f = frames[i];
      path = f.object ? (path.empty() ? f.key : path + "." + f.key) : path + "[" + std::to_string(f.index) + "]";
    }
    if (frames.size() > kShown) path += "...";
    return path;
  };
  auto open = [&](bool object) {
    if (frames.size() >= kMaxJsonDepth) {
      const std::string path = current_path();
      throw Error(what + ": " + (path.empty() ? "" : path + ": ") + "nested deeper than " +
                  std::to_string(kMaxJsonDepth) + " levels of arrays and objects (the limit for JSON input)");
    }
    frames.push_back({object, "", 0, {}});
  };
  Json::parser_callback_t callback = [&](int, Json::parse_event_t event, Json& parsed) {
    switch (event) {
      case Json::parse_event_t::object_start:
        open(true);
        break;
      case Json::parse_event_t::array_start:
        open(false);
        break;
      case Json::parse_event_t::key: {
        Frame& top = frames.back();
        top.key = parsed.get<std::string>();
        if (!top.keys.insert(top.key).second) {
          const std::string path = current_path();
          throw Error(what + ": duplicate key '" + path + "'");
        }
        if (top.keys.size() > kMaxJsonKeys) {
          frames.pop_back();  // the path of the object, not of its last key
          const std::string path = current_path();
          throw Error(what + ": " + (path.empty() ? "" : path + ": ") + "more than " +
                      std::to_string(kMaxJsonKeys) + " keys in one object (the limit for JSON input)");
        }
        break;
      }
      case Json::parse_event_t::object_end:
      case Json::parse_event_t::array_end:
        frames.pop_back();
        element_done();
        break;
      case Json::parse_event_t::value:
        element_done();
        break;
    }
    return true;
  };
  try {
    return Json::parse(text, callback, /*allow_exceptions=*/true, /*ignore_comments=*/true);
  } catch (const Json::parse_error& e) {
    std::string message = without_tag(e.what());
    if (message.rfind("parse error", 0) != 0) message = "parse error: " + message;
    throw Error(what + ": " + message);
  } catch (const Json::out_of_range& e) {
    // A number beyond double range, e.g. 1e999: the frames still point at it.
    const std::string path = current_path();
    throw Error(what + ": " + (path.empty() ? "" : path + ": ") + without_tag(e.what()) +
                " (not a finite number: NaN/Inf)");
  }
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

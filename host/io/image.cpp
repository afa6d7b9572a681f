#include "host/io/image.h"

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <vector>

#include <jpeglib.h>

#include "firmware/render_scene.h"
#include "host/io/error.h"
#include "host/io/files.h"
#include "host/io/limits.h"
#include "hwmodel/format/prim_kinds.h"

// stb's implementations, compiled here without the warnings they raise.
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#endif
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>

#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG  // PNG by stb; JPEG (glTF's other image format) by libjpeg-turbo, below
// Zeroed allocations: a corrupt image can leave texels the decoder never writes, which must not take whatever the
// heap held (the same bytes must give the same texture; a fuzz target holds file and memory reads to it).
#define STBI_MALLOC(sz) std::calloc(1, (sz) > 0 ? size_t(sz) : 1)
#define STBI_REALLOC(p, newsz) std::realloc(p, newsz)
#define STBI_FREE(p) std::free(p)
#include <stb/stb_image.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

namespace rtu::host {

void write_png(const std::string& path, const Image& img) {
  if (img.width <= 0 || img.height <= 0 || img.rgb.size() != size_t(img.width) * size_t(img.height) * 3)
    throw Error(path + ": invalid image");
  check_output_file(path);
  errno = 0;
  if (!stbi_write_png(path.c_str(), img.width, img.height, 3, img.rgb.data(), img.width * 3))
    throw Error(path + ": cannot write PNG" + (errno ? std::string(" (") + std::strerror(errno) + ")" : ""));
}

Image read_png(const std::string& path) {
  check_input_file(path);
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) throw Error(path + ": cannot open (" + std::strerror(errno) + ")");
  int w = 0, h = 0, channels = 0;
  const std::unique_ptr<stbi_uc, void (*)(void*)> data(stbi_load_from_file(f.get(), &w, &h, &channels, 3),
                                                       &stbi_image_free);
  if (!data) {
    const char* why = stbi_failure_reason();
    throw Error(path + ": cannot read PNG (" + (why ? why : "unknown reason") + ")");
  }
  Image img{w, h, {}};
  img.rgb.assign(data.get(), data.get() + size_t(w) * size_t(h) * 3);
  return img;
}

namespace {

Texture texture_from(stbi_uc* data, int w, int h, const std::string& name) {
  const std::unique_ptr<stbi_uc, void (*)(void*)> own(data, &stbi_image_free);
  if (!data) {
    const char* why = stbi_failure_reason();
    throw Error(name + ": cannot read texture (" + (why ? why : "unknown reason") + ")");
  }
  Texture t{name, uint32_t(w), uint32_t(h), {}};
  t.rgba.assign(data, data + size_t(w) * size_t(h) * 4);
  return t;
}

void check_texture_size(int w, int h, const std::string& name) {
  if (w < 1 || h < 1 || w > int(fw::kMaxTextureSide) || h > int(fw::kMaxTextureSide))
    throw Error(name + ": texture of " + std::to_string(w) + " x " + std::to_string(h) +
                " texels (each side must be in [1, " + std::to_string(fw::kMaxTextureSide) + "])");
  // A header is a few bytes and may claim a 1 GiB image: the decoder's buffer and the copy are refused before
  // they are allocated when they do not fit the memory limit.
  check_memory(name + ": decoding a " + std::to_string(w) + " x " + std::to_string(h) + " texture",
               uint64_t(w) * uint64_t(h) * 8);
}

}  // namespace

// Debian 12's stb_image trusts a PNG's chunk lengths: it grows its compressed-data buffer to an IDAT chunk's
// declared length before reading it (a 262-byte file declaring a 2 GiB chunk makes it allocate 2 GiB), and it
// copies the first IDAT chunk to a buffer it has not allocated yet when that chunk is empty (memcpy from a null
// pointer, undefined even for 0 bytes). Every chunk up to IEND is checked here first: its data and CRC must be
// in the file, so stb's buffer never exceeds twice the file's size (it doubles to fit).
static void check_png_chunks(const uint8_t* data, size_t bytes, const std::string& name) {
  static const uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (bytes < 8 || std::memcmp(data, kSignature, 8) != 0) return;
  bool idat_seen = false;
  for (size_t at = 8; at + 8 <= bytes;) {
    const uint32_t len = uint32_t(data[at]) << 24 | uint32_t(data[at + 1]) << 16 | uint32_t(data[at + 2]) << 8 |
                         uint32_t(data[at + 3]);
    if (uint64_t(len) + 12 > bytes - at)
      throw Error(name + ": cannot read texture (a PNG chunk declares " + std::to_string(len) +
                  " bytes at offset " + std::to_string(at) + ", past the file's end at " + std::to_string(bytes) +
                  ")");
    if (std::memcmp(data + at + 4, "IDAT", 4) == 0) {
      if (len == 0 && !idat_seen)
        throw Error(name + ": cannot read texture (a PNG whose first IDAT chunk is empty)");
      idat_seen = true;
    }
    if (std::memcmp(data + at + 4, "IEND", 4) == 0) return;
    at += size_t(len) + 12;
  }
}

Texture read_texture(const std::string& path) {
  // Read whole (textures are bounded by the memory limit at decoding), so that file and memory take one path.
  check_input_file(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open (" + std::strerror(errno) + ")");
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw Error(path + ": cannot read");
  return read_texture_memory(bytes.data(), bytes.size(), path);
}

namespace {

// JPEG by libjpeg-turbo: Debian 12's stb_image decodes corrupt JPEG entropy data with undefined shifts (its bit
// buffer's count goes negative after a marker ends the data early; the fuzzer found it) and writes past its
// Huffman table for a DHT segment of more than 256 codes. libjpeg reports errors through error_exit, which must
// not return: it jumps back to the setjmp of the call that failed. Between the setjmp and a libjpeg call, only
// the decoder's heap state changes (no automatic object that a jump would leave inconsistent).
struct JpegDecoder {
  jpeg_decompress_struct cinfo{};
  struct Error {
    jpeg_error_mgr mgr;
    std::jmp_buf jump;
    char message[JMSG_LENGTH_MAX];
  } err{};
  bool created = false;
  ~JpegDecoder() {
    if (created) jpeg_destroy_decompress(&cinfo);
  }
};

extern "C" void jpeg_fail(j_common_ptr c) {
  JpegDecoder::Error* e = reinterpret_cast<JpegDecoder::Error*>(c->err);
  (*c->err->format_message)(c, e->message);
  std::longjmp(e->jump, 1);
}
// Warnings (corrupt data the decoder goes on past) are not printed: the texture is what it decoded.
extern "C" void jpeg_quiet(j_common_ptr, int) {}

bool jpeg_header(JpegDecoder& d, const uint8_t* data, size_t bytes, uint64_t budget) {
  d.cinfo.err = jpeg_std_error(&d.err.mgr);
  d.err.mgr.error_exit = jpeg_fail;
  d.err.mgr.emit_message = jpeg_quiet;
  if (setjmp(d.err.jump)) return false;
  jpeg_create_decompress(&d.cinfo);
  d.created = true;
  // The decoder's own buffers (a progressive file's coefficients: the whole image) within the budget; without a
  // backing store, libjpeg-turbo fails with an error rather than take more.
  d.cinfo.mem->max_memory_to_use = long(std::min<uint64_t>(budget, uint64_t(LONG_MAX)));
  jpeg_mem_src(&d.cinfo, data, static_cast<unsigned long>(bytes));
  jpeg_read_header(&d.cinfo, TRUE);
  return true;
}

// Decodes into rgba (output_width x output_height x 4 bytes, allocated by the caller after jpeg_header).
bool jpeg_pixels(JpegDecoder& d, uint8_t* rgba) {
  if (setjmp(d.err.jump)) return false;
  d.cinfo.out_color_space = JCS_EXT_RGBA;  // libjpeg-turbo: grey and YCbCr to RGBA, alpha 255
  jpeg_start_decompress(&d.cinfo);
  while (d.cinfo.output_scanline < d.cinfo.output_height) {
    JSAMPROW row = rgba + size_t(d.cinfo.output_scanline) * size_t(d.cinfo.output_width) * 4;
    jpeg_read_scanlines(&d.cinfo, &row, 1);
  }
  jpeg_finish_decompress(&d.cinfo);
  return true;
}

bool is_jpeg(const uint8_t* data, size_t bytes) {
  return bytes >= 3 && data[0] == 0xFF && data[1] == 0xD8 && data[2] == 0xFF;
}

Texture read_jpeg(const uint8_t* data, size_t bytes, const std::string& name) {
  auto d = std::make_unique<JpegDecoder>();
  if (!jpeg_header(*d, data, bytes, memory_limit()))
    throw Error(name + ": cannot read texture (JPEG: " + d->err.message + ")");
  const JDIMENSION w = d->cinfo.image_width, h = d->cinfo.image_height;
  check_texture_size(int(std::min<JDIMENSION>(w, INT_MAX)), int(std::min<JDIMENSION>(h, INT_MAX)), name);
  Texture t{name, uint32_t(w), uint32_t(h), std::vector<uint8_t>(size_t(w) * size_t(h) * 4, 0)};
  if (!jpeg_pixels(*d, t.rgba.data())) throw Error(name + ": cannot read texture (JPEG: " + d->err.message + ")");
  if (d->cinfo.output_width != w || d->cinfo.output_height != h)
    throw Error(name + ": cannot read texture (JPEG: decoded size differs from the header's)");
  return t;
}

}  // namespace

Texture read_texture_memory(const uint8_t* data, size_t bytes, const std::string& name) {
  if (bytes == 0 || bytes > size_t(INT32_MAX)) throw Error(name + ": cannot read texture (empty or over 2 GiB)");
  if (is_jpeg(data, bytes)) return read_jpeg(data, bytes, name);
  check_png_chunks(data, bytes, name);
  int w = 0, h = 0, channels = 0;
  if (!stbi_info_from_memory(data, int(bytes), &w, &h, &channels)) {
    const char* why = stbi_failure_reason();
    throw Error(name + ": cannot read texture (" + (why ? why : "unknown format") + ")");
  }
  check_texture_size(w, h, name);
  return texture_from(stbi_load_from_memory(data, int(bytes), &w, &h, &channels, 4), w, h, name);
}

hw::Vec3 hit_normal(const hw::Geometry& g, const hw::Ray& ray, const hw::Hit& hit) {
  const hw::Vec3 n = hw::prim_normal(g, hit.prim, ray.origin + hit.t * ray.dir, hit.u);
  const float len = glm::length(n);
  return len > 0.0f ? n / len : hw::Vec3(0.0f, 0.0f, 1.0f);
}

Image shade_hits(const Scene& scene, const std::vector<hw::Ray>& rays, const std::vector<hw::Hit>& hits, int width,
                 int height) {
  Image img{width, height, std::vector<uint8_t>(size_t(width) * size_t(height) * 3, 0)};
  const size_t n = std::min(hits.size(), size_t(width) * size_t(height));
  for (size_t i = 0; i < n; ++i) {
    const hw::Hit& h = hits[i];
    if (!h.hit()) continue;
    const Material& m = scene.materials[scene.prim_material[h.prim]];
    const hw::Vec3 base = m.type == MaterialType::kEmissive ? glm::min(m.emission, hw::Vec3(1.0f)) : m.color;
    const float facing = std::abs(glm::dot(hit_normal(scene.geometry, rays[i], h), glm::normalize(rays[i].dir)));
    const hw::Vec3 c = base * (0.15f + 0.85f * facing);
    for (int k = 0; k < 3; ++k)
      img.rgb[3 * i + size_t(k)] = uint8_t(std::lround(255.0f * std::pow(std::clamp(c[k], 0.0f, 1.0f), 1 / 2.2f)));
  }
  return img;
}

namespace {

// The width and height a PNG or JPEG declares, as stb_image reads them (PNG: the IHDR chunk that must come first;
// JPEG: the first frame header, SOF0..SOF2, after the start of image and any fill bytes), from `read(offset, n,
// out)`, which returns the bytes it could read. {0, 0}: the header declares none, or not in a way stb takes.
template <class Read>
std::pair<uint64_t, uint64_t> declared_size(Read&& read) {
  uint8_t b[24];
  auto be = [&](int at, int n) {
    uint64_t v = 0;
    for (int i = 0; i < n; ++i) v = v << 8 | b[at + i];
    return v;
  };
  static const uint8_t kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (read(0, 24, b) == 24 && std::memcmp(b, kPng, 8) == 0 && std::memcmp(b + 12, "IHDR", 4) == 0)
    return {be(16, 4), be(20, 4)};
  uint64_t at = 0;  // stb takes any number of fill bytes before the start of image
  auto byte = [&](uint64_t i) { return read(i, 1, b) == 1 ? int(b[0]) : -1; };
  while (byte(at) == 0xFF) ++at;
  if (at == 0 || byte(at) != 0xD8) return {0, 0};
  ++at;
  for (;;) {
    // stb looks for the next marker: 0xFF, fill bytes, then the marker's code.
    int c = byte(at);
    for (int skipped = 0; c >= 0 && c != 0xFF; ++skipped) {
      if (skipped == 65536) return {0, 0};  // not a JPEG stb reads: no need to scan on
      c = byte(++at);
    }
    while (c == 0xFF) c = byte(++at);
    if (c < 0) return {0, 0};
    ++at;
    if (c >= 0xC0 && c <= 0xC2) {  // a frame header: length, precision, height, width
      if (read(at, 7, b) != 7) return {0, 0};
      return {be(5, 2), be(3, 2)};
    }
    // Before its frame header stb takes tables (DQT, DHT), a restart interval (DRI), application segments and
    // comments; any other marker fails the file.
    if (c != 0xDB && c != 0xC4 && c != 0xDD && !(c >= 0xE0 && c <= 0xEF) && c != 0xFE) return {0, 0};
    if (read(at, 2, b) != 2) return {0, 0};
    at += be(0, 2);
  }
}

// RGBA8 bytes of a declared size; 0 for none, and for sides read_texture refuses anyway (with its own message).
uint64_t rgba_bytes(std::pair<uint64_t, uint64_t> size) {
  const auto [w, h] = size;
  if (w < 1 || h < 1 || w > fw::kMaxTextureSide || h > fw::kMaxTextureSide) return 0;
  return w * h * 4;
}

}  // namespace

uint64_t texture_header_bytes(const uint8_t* data, size_t bytes) {
  return rgba_bytes(declared_size([&](uint64_t at, size_t n, uint8_t* out) -> size_t {
    if (at >= bytes) return 0;
    n = size_t(std::min<uint64_t>(n, bytes - at));
    std::memcpy(out, data + at, n);
    return n;
  }));
}

uint64_t texture_header_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return 0;
  return rgba_bytes(declared_size([&](uint64_t at, size_t n, uint8_t* out) -> size_t {
    in.clear();
    in.seekg(std::streamoff(at));
    in.read(reinterpret_cast<char*>(out), std::streamsize(n));
    return size_t(in.gcount());
  }));
}

}  // namespace rtu::host

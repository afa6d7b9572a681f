// The one way rtu reads JSON (docs/guide/hardening.md): every JSON input, a scene description file or a file
// that a test reads back, goes through parse_json_limited, which bounds the nesting depth while it parses.
//
// Why a bound: nlohmann-json parses iteratively, but copying a value (basic_json's copy constructor), dump() and
// comparisons recurse once per level of nesting. A 2 MB file of 10^6 nested arrays parses, then overflows the
// call stack as soon as the reader copies it or names it in an error message (issue 25: `rtusim info --scene F`
// died by SIGSEGV). Refusing the file while parsing, before any value deeper than the limit exists, makes every
// later recursion shallow.
#pragma once

#include <cstddef>
#include <string>

#include <nlohmann/json.hpp>

namespace rtu::host {

// The deepest nesting of arrays and objects accepted (the top-level value counts 1). The files rtu reads or writes
// nest at most 6 levels (measured: a scene file 5, root > "meshes" > a mesh > "transform" > "rotate"; stats JSON
// 5; report.json 6; tests/host/test_cli.cpp reads rtusim's JSON back through this parser, so one deeper than 64
// would fail there), so 64 leaves a wide margin for hand-written files while every recursion over a parsed value
// stays below 64 frames of a few hundred bytes: a few tens of KiB of stack, even under AddressSanitizer.
inline constexpr size_t kMaxJsonDepth = 64;

// Parses `text` as JSON. `what` names the input in messages (a file name). Throws host::Error:
//  - "WHAT: parse error at line L, column C: ..." for text that is not JSON;
//  - "WHAT: PATH: nested deeper than 64 levels of arrays and objects (the limit for JSON input)" when an array or
//    object opens at depth kMaxJsonDepth + 1, before it is built;
//  - "WHAT: duplicate key 'PATH'" (nlohmann would keep the last one silently);
//  - "WHAT: PATH: ... (not a finite number: NaN/Inf)" for a number beyond double range (1e999).
// PATH is the key path of the offending value, e.g. "meshes[2].transform" (shortened when long). Comments
// (// and /* */) are allowed, as in scene files. Objects keep their members in file order; a parse takes time
// about proportional to the text (n log n in an object's keys), whatever the number of keys.
nlohmann::ordered_json parse_json_limited(const std::string& text, const std::string& what);

// Reads the file `path` and parses it with parse_json_limited (path names it). Throws host::Error when the file
// is missing, not a regular file, unreadable, or larger than the memory budget (host/io/limits.h) allows.
nlohmann::ordered_json read_json_file(const std::string& path);

}  // namespace rtu::host

// Reading CSV fields (RFC 4180 quoting), for the sweep CSV and the RTL area and activity tables. Errors name the
// place: `where` is "file:line".
#pragma once

#include <charconv>
#include <string>
#include <vector>

#include "host/io/error.h"

namespace rtu::host {

// The fields of one line; a quoted field may hold commas and doubled quotes.
std::vector<std::string> split_csv(const std::string& line);

// A number field ("inf" and "-inf" too). Throws Error naming `where` for anything else.
double parse_csv_double(const std::string& s, const std::string& where);

// An integer field of type Int. Throws Error naming `where` for anything else.
template <class Int>
Int parse_csv_int(const std::string& s, const std::string& where) {
  Int v = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size() || s.empty())
    throw Error(where + ": '" + s + "' is not an integer");
  return v;
}

}  // namespace rtu::host

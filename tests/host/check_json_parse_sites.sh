#!/usr/bin/env bash
# Every JSON parse of rtu goes through host/io/json_io.cpp, the one parser with a nesting limit (issue 25: a deeply
# nested file overflowed the stack). Fails, listing them, when a source file of the project calls nlohmann's
# parsers (parse, sax_parse, the binary formats) anywhere else; the parser's own test (tests/host/test_json_io.cpp)
# uses nlohmann's parser as its oracle, on documents it generates. Usage: check_json_parse_sites.sh SOURCE_DIR
set -uo pipefail
cd "$1" || exit 2
sites=$(grep -rnE '(json|Json)(::|\.)(parse|sax_parse|from_(cbor|msgpack|ubjson|bson|bjdata))[[:space:]]*\(' \
  --include='*.cpp' --include='*.h' --include='*.hpp' host hwmodel firmware rtl_sim bench tests |
  grep -v -e '^host/io/json_io\.cpp:' -e '^tests/host/test_json_io\.cpp:')
if [ -n "$sites" ]; then
  echo "JSON parsed outside host/io/json_io.cpp (use host::parse_json_limited or host::read_json_file):" >&2
  echo "$sites" >&2
  exit 1
fi
echo "every JSON parse goes through host/io/json_io.cpp"

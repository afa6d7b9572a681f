# Shared by the bench scripts (source it after setting `name` to the script's name): argument checks that exit 2
# with a message naming the script, and a temporary directory removed on exit.
bench_need_rtusim() {  # bench_need_rtusim PATH
  [ -x "$1" ] || { echo "$name: $1 is not an executable (build the rtusim target, or pass its path)" >&2; exit 2; }
}
bench_need_count() {  # bench_need_count WHAT VALUE: a positive integer
  [[ $2 =~ ^[1-9][0-9]*$ ]] || { echo "$name: $1 must be a positive integer, not '$2'" >&2; exit 2; }
}
bench_need_python() {
  command -v python3 >/dev/null || { echo "$name: needs python3 to read the stats JSON" >&2; exit 2; }
}
bench_tmpdir() {  # sets tmp
  tmp=$(mktemp -d)
  trap 'rm -rf "$tmp"' EXIT
}

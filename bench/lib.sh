# Shared by the bench scripts (source it after setting `name` to the script's name, or let it be the file's): argument
# checks that exit 2 with a message naming the script, and a temporary directory removed on exit.
name=${name:-${0##*/}}
bench_need_rtusim() {  # bench_need_rtusim PATH
  [ -x "$1" ] || { echo "$name: $1 is not an executable (build the rtusim target, or pass its path)" >&2; exit 2; }
}
bench_need_count() {  # bench_need_count WHAT VALUE: a positive integer
  [[ $2 =~ ^[1-9][0-9]*$ ]] || { echo "$name: $1 must be a positive integer, not '$2'" >&2; exit 2; }
}
bench_need_python() {
  command -v python3 >/dev/null || { echo "$name: needs python3 to read the stats JSON" >&2; exit 2; }
}
num() {  # num PATH FILE: a number from the stats JSON, by a Python-style path
  python3 -c "import json,sys; d=json.load(open(sys.argv[2])); print(eval('d'+sys.argv[1]))" "$1" "$2"
}
least() { awk -v a="$1" -v b="$2" 'BEGIN{print (a == "" || b < a) ? b : a}'; }  # least A B: the smaller; A may be empty
bench_tmpdir() {  # sets tmp
  tmp=$(mktemp -d)
  trap 'rm -rf "$tmp"' EXIT
}

# The assimp-testmodels meshes the scripts trace by default.
bench_house=/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc
bench_engine=/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb
bench_suzanne=/usr/share/assimp/models/BLEND/SuzanneSubdiv_252.blend

# bench_rays_args DEFAULT_RAYS [RTUSIM] [RAYS]: the first arguments of a script that traces rays. Sets rtusim
# (default build/default/rtusim) and rays (default DEFAULT_RAYS), and checks them.
bench_rays_args() {
  rtusim=${2:-build/default/rtusim}
  rays=${3:-$1}
  bench_need_rtusim "$rtusim"
  bench_need_count RAYS "$rays"
}

# bench_split_args N DEFAULT... -- ARG...: sets bench_lead to the first N ARGs (those given) and bench_list to the
# ARGs after them, or to the DEFAULTs when there are none.
bench_split_args() {
  local n=$1 defaults=()
  shift
  while [ "$1" != -- ]; do
    defaults+=("$1")
    shift
  done
  shift
  bench_lead=("${@:1:n}")
  shift $(($# > n ? n : $#))
  bench_list=("$@")
  [ ${#bench_list[@]} -gt 0 ] || bench_list=("${defaults[@]}")
}

# bench_mesh_args DEFAULT_RAYS DEFAULT_MESH... -- [RTUSIM] [RAYS] [MESH...]: the arguments of a script that traces
# meshes. Sets rtusim (default build/default/rtusim), rays and meshes, and checks rtusim and RAYS.
bench_mesh_args() {
  local default_rays=$1
  shift
  bench_split_args 2 "$@"
  meshes=("${bench_list[@]}")
  bench_rays_args "$default_rays" "${bench_lead[@]}"
}

# bench_mesh_setup DEFAULT_RAYS DEFAULT_MESH... -- [RTUSIM] [RAYS] [MESH...]: bench_mesh_args, then what the
# scripts that read the stats JSON with python3 need beside it: python3 (bench_need_python) and $tmp (bench_tmpdir).
bench_mesh_setup() {
  bench_mesh_args "$@"
  bench_need_python
  bench_tmpdir
}

# bench_scene_args DEFAULT_SCENE... -- [RTUSIM] [SCENE...]: the arguments of a script that renders or traces
# scenes. Sets rtusim (default build/default/rtusim) and scenes, and checks rtusim.
bench_scene_args() {
  bench_split_args 1 "$@"
  scenes=("${bench_list[@]}")
  rtusim=${bench_lead[0]:-build/default/rtusim}
  bench_need_rtusim "$rtusim"
}

# bench_kind_rays MESH: checks that MESH is readable (exits 2 when not) and writes $rays primary and as many
# incoherent rays of it to $tmp/primary.bin and $tmp/incoherent.bin (bench_tmpdir).
bench_kind_rays() {
  [ -r "$1" ] || { echo "$name: cannot read $1" >&2; exit 2; }
  local kind
  for kind in primary incoherent; do
    "$rtusim" rays --scene "$1" --kind "$kind" --count "$rays" --out "$tmp/$kind.bin" >/dev/null
  done
}

# Sets reader to jq, or python3 when jq is missing; exits 2 when neither is there.
bench_json_reader() {
  if command -v jq >/dev/null; then
    reader=jq
  elif command -v python3 >/dev/null; then
    reader=python3
  else
    echo "$name: needs jq or python3 to read the stats JSON" >&2
    exit 2
  fi
}

# bench_fields FILE PATH...: the values at the dotted paths of a stats JSON, tab-separated, '-' where a path is
# missing or null (read with $reader, bench_json_reader).
bench_fields() {
  local file=$1
  shift
  if [ "$reader" = jq ]; then
    jq -r '[$ARGS.positional[] as $p | getpath($p | split(".")) | if . == null then "-" else tostring end] | @tsv' \
      "$file" --args "$@"
  else
    python3 - "$file" "$@" <<'PY'
import json, sys
doc = json.load(open(sys.argv[1]))
out = []
for path in sys.argv[2:]:
    v = doc
    for k in path.split("."):
        v = v.get(k) if isinstance(v, dict) else None
    out.append("-" if v is None else (str(v).lower() if isinstance(v, bool) else str(v)))
print("\t".join(out))
PY
  fi
}

# bench_yosys_stat SCRIPT: runs yosys on SCRIPT, which writes its `stat -tech cmos` to $tmp/stat.txt (exits 1 with
# yosys's log when it fails); sets secs (yosys's wall seconds), cells, ffs (flip-flops) and trans (the CMOS
# transistor estimate, as yosys prints it).
bench_yosys_stat() {
  local t0
  t0=$(date +%s)
  yosys -q "$1" >"$tmp/yosys.log" 2>&1 || { cat "$tmp/yosys.log" >&2; exit 1; }
  secs=$(( $(date +%s) - t0 ))
  cells=$(sed -n 's/^ *Number of cells: *\([0-9]*\)/\1/p' "$tmp/stat.txt" | tail -1)
  ffs=$(grep -E '^\s+\$_(S?DFF|DFF)[A-Z_0-9]*\s' "$tmp/stat.txt" | awk '{s+=$2} END{print s+0}')
  trans=$(sed -n 's/^ *Estimated number of transistors: *\([0-9+]*\)/\1/p' "$tmp/stat.txt" | tail -1)
}

# bench_synth_row PREFIX KEY TOP SV [CHPARAM...]: synthesizes module TOP of SV with yosys (chparam -set of the pairs
# given, synth -flatten, check -assert, stat -tech cmos) in $tmp (bench_tmpdir) and puts the row
# KEY,cells,flip_flops,transistors into bench/data/rtl_area.csv, replacing one of that key; prints it after PREFIX.
bench_synth_row() {
  local prefix=$1 key=$2 top=$3 sv=$4 area
  shift 4
  area="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/data/rtl_area.csv"
  {
    echo "read_verilog -sv $sv"
    [ $# -eq 0 ] || echo "chparam $(printf -- '-set %s %s ' "$@")$top"
    echo "synth -flatten -top $top"
    echo "check -assert"
    echo "tee -o $tmp/stat.txt stat -tech cmos"
  } >"$tmp/s.ys"
  local secs cells ffs trans
  bench_yosys_stat "$tmp/s.ys"
  grep -v -- "^$key," "$area" >"$tmp/area.csv" || true
  echo "$key,$cells,$ffs,${trans%+}" >>"$tmp/area.csv"
  cp "$tmp/area.csv" "$area"
  echo "$prefix$key: $cells cells, $ffs flip-flops, ${trans%+} transistors (est.) -> $area"
}

# bench_report_context OUT ROOT: what a results file written whole keeps and names. Sets notes (OUT's "## Notes"
# section to its end, written by hand and kept across runs; empty when none), commit (ROOT's), cpu and os.
bench_report_context() {
  notes=""
  if [ -f "$1" ] && grep -q '^## Notes' "$1"; then
    notes=$(sed -n '/^## Notes/,$p' "$1")
  fi
  commit=$(git -C "$2" rev-parse --short HEAD 2>/dev/null || echo unknown)
  cpu=$(grep -m1 'model name' /proc/cpuinfo 2>/dev/null | sed 's/.*: //' || echo unknown)
  os=$( (. /etc/os-release && echo "$PRETTY_NAME") 2>/dev/null || uname -s)
}

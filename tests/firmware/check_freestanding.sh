#!/usr/bin/env bash
# Checks that the firmware library is freestanding: the only symbols it may take from outside itself are the
# memory primitives a freestanding compiler may emit calls to (memcpy, memset, memmove, memcmp) and, in a
# sanitizer build, the sanitizer runtime (__asan_*, __ubsan_*, __sanitizer_*, clang's coverage __sancov_*), and
# under -fPIC the linker's _GLOBAL_OFFSET_TABLE_. Anything else (malloc/free,
# operator new/delete, __cxa_* and _Unwind_* of exceptions, stdio, libm, the C++ library...) fails the check.
#
# usage: check_freestanding.sh LIBRARY.a [NM]
# exit:  0 clean; 1 a symbol outside the allow-list (each printed, demangled beside it); 2 usage or nm error.
set -euo pipefail

if [[ $# -lt 1 || $# -gt 2 ]]; then
  echo "usage: $0 LIBRARY.a [NM]" >&2
  exit 2
fi
lib=$1
nm=${2:-nm}
if [[ ! -f $lib ]]; then
  echo "check_freestanding: no such file: $lib" >&2
  exit 2
fi

# Symbols the archive defines itself (one member may use another's) are not external references.
if ! defined=$("$nm" --defined-only --format=posix "$lib" 2>&1); then
  echo "check_freestanding: $nm failed on $lib: $defined" >&2
  exit 2
fi
if ! undefined=$("$nm" --undefined-only --format=posix "$lib" 2>&1); then
  echo "check_freestanding: $nm failed on $lib: $undefined" >&2
  exit 2
fi
# posix format: "NAME TYPE [VALUE SIZE]"; member headers look like "lib.a[member.o]:" and are skipped.
defined_names=$(awk 'NF >= 2 && $1 !~ /:$/ { print $1 }' <<<"$defined" | sort -u)
undefined_names=$(awk 'NF >= 2 && $1 !~ /:$/ { print $1 }' <<<"$undefined" | sort -u)
external=$(comm -23 <(printf '%s\n' "$undefined_names") <(printf '%s\n' "$defined_names") | sed '/^$/d')

bad=0
checked=0
while IFS= read -r sym; do
  [[ -z $sym ]] && continue
  checked=$((checked + 1))
  case $sym in
    memcpy | memset | memmove | memcmp) ;;
    __asan_* | __ubsan_* | __sanitizer_*) ;;
    # clang's coverage instrumentation (the asan preset builds with -fsanitize=fuzzer-no-link): its counters and
    # the linker's section bounds; and the type_info vtable -fsanitize=function (clang's UBSan) compares with.
    __sancov_* | __start___sancov_* | __stop___sancov_* | _ZTVN10__cxxabiv120__function_type_infoE) ;;
    # Position-independent code (the Python module links the firmware into a shared object) addresses its data
    # through the GOT; the linker defines this symbol, no library does.
    _GLOBAL_OFFSET_TABLE_) ;;
    *)
      demangled=$(c++filt "$sym" 2>/dev/null || echo "$sym")
      echo "not allowed in the firmware: $sym ($demangled)"
      bad=1
      ;;
  esac
done <<<"$external"

if [[ $bad -ne 0 ]]; then
  echo "check_freestanding: $lib references symbols outside the freestanding allow-list" >&2
  exit 1
fi
echo "check_freestanding: $lib is freestanding ($checked external symbols, all allowed)"

// The sanitizers' options of the asan build, compiled into each of its executables (tests, rtusim, the fuzz
// targets; CMakeLists.txt links this file into every one): the one place they are written, so that ctest, the
// soak and fuzz runs of scripts/test.sh, scripts/fuzz_long.sh and a target run by hand all get the same ones.
// The sanitizer runtimes call these hooks at start-up; an ASAN_OPTIONS, UBSAN_OPTIONS or LSAN_OPTIONS in the
// environment still overrides them option by option.
//  - ASan: leaks are errors, and any report aborts (a core, and libFuzzer keeps the input);
//  - UBSan: every report stops the run with its stack (the build also has -fno-sanitize-recover=undefined);
//  - LSan: lsan.supp's suppressions (Assimp's own leaks only), without printing the list of those applied.

#ifndef RTU_LSAN_SUPPRESSIONS
#error "RTU_LSAN_SUPPRESSIONS (the path of tests/fuzz/lsan.supp) must be defined"
#endif

extern "C" {

const char* __asan_default_options() {
  return "detect_leaks=1:abort_on_error=1";
}
const char* __ubsan_default_options() {
  return "print_stacktrace=1:halt_on_error=1";
}
const char* __lsan_default_options() {
  return "suppressions=" RTU_LSAN_SUPPRESSIONS ":print_suppressions=0";
}

}  // extern "C"

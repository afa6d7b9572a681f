// Assimp in a child process, on a stack of known size: a file on which it aborts, hangs (RTU_IMPORT_TIMEOUT),
// overflows its stack or leaks costs an Error naming the file, never rtusim (docs/guide/hardening.md).
#include <poll.h>
#include <pthread.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>
#include <vector>

#include "host/io/error.h"
#include "host/io/limits.h"
#include "host/scene/mesh_import_internal.h"

namespace rtu::host::mesh_detail {
namespace {

bool write_all(int fd, const void* data, size_t n) {
  const auto* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    p += w;
    n -= size_t(w);
  }
  return true;
}

// Assimp's parsers and its scene recurse once per level of nesting: rapidjson under glTF (nested arrays), the
// Collada, DirectX .x and AC3D node readers (nested <node> elements, Frames, kids), aiNode's destructor. Measured
// on Assimp 5.2.5 with an 8 MiB stack (tests/host/test_nesting.cpp builds such files): a Collada node chain of
// 10^4 levels overflows it (at least 800 bytes a level), glTF arrays 2 x 10^5 deep do (40-80 bytes a level; 10^5
// do not). Each format nests in its own syntax, so rather than pre-scan each, the import runs on a stack rtu
// allocates itself: kImportStackBytes, whatever `ulimit -s` says (an unlimited stack would let a deep file eat
// memory until the machine runs out), 8 times the usual default (ample for real models, whose node trees nest
// tens of levels), with kStackGuardBytes without access below it. A fault in the guard is a stack overflow: the
// handler, on its own small stack, sends the child's error message ("nests too deeply") through the pipe and
// exits, so the parent reports it as an Error like any other. Other faults die by the signal as before.
constexpr size_t kImportStackBytes = size_t(64) << 20;
// Larger than any frame Assimp pushes, so an overflowing call lands in the guard, not in a mapping beyond it.
constexpr size_t kStackGuardBytes = size_t(16) << 20;

// What the overflow handler needs, set before the import thread starts (the handler may not allocate).
struct OverflowReport {
  int fd = -1;
  const char* message = nullptr;
  size_t length = 0;
  uintptr_t guard_lo = 0, guard_hi = 0;
};
OverflowReport g_overflow;

extern "C" void on_import_fault(int sig, siginfo_t* info, void*) {
  const auto addr = reinterpret_cast<uintptr_t>(info->si_addr);
  if (addr >= g_overflow.guard_lo && addr < g_overflow.guard_hi) {
    // write() and _exit() are async-signal-safe; write_all only loops over write().
    const uint64_t head[2] = {1, g_overflow.length};
    const bool ok = write_all(g_overflow.fd, head, sizeof head) &&
                    write_all(g_overflow.fd, g_overflow.message, g_overflow.length);
    ::_exit(ok ? 0 : 3);
  }
  // Not an overflow: back to the default action; the faulting instruction runs again and the child dies by `sig`.
  ::signal(sig, SIG_DFL);
}

// The import's outcome, filled by the import thread.
struct ImportJob {
  std::string path;
  std::string blob;   // the answer (import_with_assimp)
  std::string error;  // empty: success
};

void run_import(ImportJob& job) {
  try {
    job.blob = import_with_assimp(job.path);
  } catch (const std::bad_alloc&) {
    job.error = out_of_memory_message(job.path + ": importing the mesh");
  } catch (const std::exception& e) {
    job.error = e.what();
  }
}

extern "C" void* import_thread(void* arg) {
  // The handler runs on this alternate stack: the thread's own stack is the one that overflowed.
  static char alt_stack[1 << 16];
  stack_t ss{}, previous{};
  ss.ss_sp = alt_stack;
  ss.ss_size = sizeof alt_stack;
  const bool replaced = ::sigaltstack(&ss, &previous) == 0;
  if (replaced) {
    struct sigaction sa {};
    sa.sa_sigaction = on_import_fault;
    sa.sa_flags = SA_SIGINFO | SA_ONSTACK;
    sigemptyset(&sa.sa_mask);
    ::sigaction(SIGSEGV, &sa, nullptr);
    ::sigaction(SIGBUS, &sa, nullptr);
  }
  run_import(*static_cast<ImportJob*>(arg));
  // Put back the alternate stack the thread started with: AddressSanitizer gives every thread one and unmaps
  // whatever is installed when the thread ends, which must not be this static buffer (found by the asan tests:
  // every import that returned aborted the child).
  if (replaced) ::sigaltstack(&previous, nullptr);
  return nullptr;
}

// Runs the import (in the child) on a kImportStackBytes stack with an overflow guard, reporting an overflow on
// `fd`. When the stack cannot be had (an address-space limit), the import runs on the calling thread instead.
void import_on_stack(ImportJob& job, int fd) {
  const size_t total = kStackGuardBytes + kImportStackBytes;
  void* base = ::mmap(nullptr, total, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
  if (base == MAP_FAILED) return run_import(job);
  if (::mprotect(base, kStackGuardBytes, PROT_NONE) != 0) {
    ::munmap(base, total);
    return run_import(job);
  }
  static std::string message;  // outlives the thread: the handler reads it
  message = job.path + ": the mesh importer (Assimp) ran out of its " + std::to_string(kImportStackBytes >> 20) +
            " MiB stack: the file nests too deeply (nodes, elements or arrays inside each other) for Assimp's "
            "recursive parsers";
  g_overflow = {fd, message.data(), message.size(), reinterpret_cast<uintptr_t>(base),
                reinterpret_cast<uintptr_t>(base) + kStackGuardBytes};
  pthread_attr_t attr;
  pthread_t thread;
  bool started = ::pthread_attr_init(&attr) == 0;
  started = started &&
            ::pthread_attr_setstack(&attr, static_cast<char*>(base) + kStackGuardBytes, kImportStackBytes) == 0;
  started = started && ::pthread_create(&thread, &attr, import_thread, &job) == 0;
  ::pthread_attr_destroy(&attr);
  if (started) {
    ::pthread_join(thread, nullptr);
  } else {
    run_import(job);
  }
  ::munmap(base, total);
}

// Assimp runs in a child process: a file that makes it crash (its assertions abort, e.g. on a PLY body that
// contradicts its header), hang or leak cannot take rtusim with it. The child sends {status, bytes} and then its
// answer (status 0: the blob of import_with_assimp) or the error message (status 1); the parent waits at most
// RTU_IMPORT_TIMEOUT seconds (default 300). Found necessary by tests/fuzz/fuzz_mesh_import.cpp (README
// "Hardening").
// The parent's side: reads the child's answer from `fd` until the child closes it, or kills the child after
// timeout_s; reaps it into `status`. Returns true on a timeout. Left out of the fuzzers'
// coverage: how the pipe splits the answer into reads, and so how often this loop turns, depends on the two
// processes' timing, and coverage that changed from run to run would make a fixed-seed fuzz run take other paths.
#if defined(__clang__)
__attribute__((no_sanitize("coverage")))
#endif
bool receive_answer(int fd, pid_t pid, int timeout_s, std::vector<char>& data, int& status) {
  // Gathered with libc's realloc and memcpy (no instrumented code runs once per read), handed over once.
  char* got = nullptr;
  size_t got_bytes = 0, got_cap = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(timeout_s);
  bool timed_out = false;
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      timed_out = true;
      break;
    }
    pollfd p{fd, POLLIN, 0};
    const int r = ::poll(&p, 1, int(std::min<int64_t>(left.count(), 1000)));
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) continue;
    char buf[1 << 16];
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // the child closed its end (exited)
    if (got_bytes + size_t(n) > got_cap) {
      const size_t cap = std::max(got_cap * 2, got_bytes + size_t(n));
      char* more = static_cast<char*>(std::realloc(got, cap));
      if (more == nullptr) break;  // the answer is then short: refused as truncated
      got = more;
      got_cap = cap;
    }
    std::memcpy(got + got_bytes, buf, size_t(n));
    got_bytes += size_t(n);
  }
  if (got != nullptr) data.assign(got, got + got_bytes);
  std::free(got);
  ::close(fd);
  if (timed_out) ::kill(pid, SIGKILL);
  status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return timed_out;
}

}  // namespace

std::string import_isolated(const std::string& path) {
  int timeout_s = 300;
  if (const char* t = std::getenv("RTU_IMPORT_TIMEOUT"); t && std::atoi(t) > 0) timeout_s = std::atoi(t);
  int fds[2];
  if (::pipe(fds) != 0) throw Error(path + ": cannot import: pipe: " + std::strerror(errno));
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    throw Error(path + ": cannot import: fork: " + std::strerror(errno));
  }
  if (pid == 0) {  // the child: import, send, _exit (no atexit handlers, no leak report of Assimp's leaks)
    ::close(fds[0]);
    // Die by the signal if Assimp crashes: no handler inherited from the parent (a sanitizer's, a fuzzer's) may
    // report the child's crash as the parent's.
    for (int sig : {SIGABRT, SIGSEGV, SIGBUS, SIGFPE, SIGILL}) std::signal(sig, SIG_DFL);
    ImportJob job{path, {}, {}};
    import_on_stack(job, fds[1]);
    const bool failed = !job.error.empty();
    const std::string& answer = failed ? job.error : job.blob;
    const uint64_t head[2] = {failed ? 1u : 0u, answer.size()};
    const bool ok = write_all(fds[1], head, sizeof head) && write_all(fds[1], answer.data(), head[1]);
    ::_exit(ok ? 0 : 3);
  }
  ::close(fds[1]);
  std::vector<char> data;
  int status = 0;
  const bool timed_out = receive_answer(fds[0], pid, timeout_s, data, status);
  if (timed_out)
    throw Error(path + ": the mesh importer (Assimp) did not finish within " + std::to_string(timeout_s) +
                " s (RTU_IMPORT_TIMEOUT); the file is malformed or too large");
  if (WIFSIGNALED(status))
    throw Error(path + ": the mesh importer (Assimp) crashed on this file (signal " +
                std::to_string(WTERMSIG(status)) + ", " + strsignal(WTERMSIG(status)) + "): a malformed file");
  uint64_t head[2] = {0, 0};
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || data.size() < sizeof head)
    throw Error(path + ": the mesh importer (Assimp) failed without a message");
  std::memcpy(head, data.data(), sizeof head);
  if (data.size() != sizeof head + head[1])
    throw Error(path + ": the mesh importer (Assimp) sent a truncated answer");
  if (head[0] != 0) throw Error(std::string(data.data() + sizeof head, head[1]));
  return std::string(data.data() + sizeof head, head[1]);
}

}  // namespace rtu::host::mesh_detail

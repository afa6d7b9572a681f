// Mesh import with Assimp, in the primitive order documented in scene.h.
//
// Only aiProcess_Triangulate and aiProcess_ValidateDataStructure are requested: steps such as
// PreTransformVertices or SortByPType reorder meshes or faces and would break the documented order. The node
// tree is walked here instead, accumulating node transforms (parent * child) into world space.
//
// Hardening (docs/guide/hardening.md): files beyond the memory budget are refused before reading; PLY headers are
// checked first (Assimp 5.2 loops for ever on some); Assimp itself runs in a child process, so a file on which it
// aborts, hangs (RTU_IMPORT_TIMEOUT) or leaks costs an Error, never rtusim. In the child it runs on a stack of
// known size, so that a file nested too deeply for Assimp's recursive parsers is named as such (import_on_stack).
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <poll.h>
#include <pthread.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>
#include <assimp/Importer.hpp>

#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "host/error.h"
#include "host/limits.h"
#include "host/scene.h"

namespace rtu::host {
namespace {

// One instance of a node in the depth-first walk, with its world transform.
struct NodeVisit {
  const aiNode* node;
  aiMatrix4x4 world;
};

std::string format_vec(const aiVector3D& v) {
  char buf[96];
  std::snprintf(buf, sizeof(buf), "(%g, %g, %g)", double(v.x), double(v.y), double(v.z));
  return buf;
}

std::string mesh_label(const aiScene& scene, unsigned mesh_index) {
  std::string label = "mesh " + std::to_string(mesh_index);
  const aiString& name = scene.mMeshes[mesh_index]->mName;
  if (name.length > 0) label += " ('" + std::string(name.C_Str()) + "')";
  return label;
}

// Calls visit(mesh_index, world) for every mesh instance: a node's meshes in order, then its children in order.
// An explicit stack, so deep node trees cannot overflow the call stack.
template <typename Visit>
void walk_nodes(const aiScene& scene, Visit&& visit) {
  if (!scene.mRootNode) return;
  std::vector<NodeVisit> stack{{scene.mRootNode, scene.mRootNode->mTransformation}};
  while (!stack.empty()) {
    NodeVisit cur = stack.back();
    stack.pop_back();
    for (unsigned i = 0; i < cur.node->mNumMeshes; ++i) visit(cur.node->mMeshes[i], cur.world);
    // Children pushed in reverse so the first child is visited first.
    for (unsigned i = cur.node->mNumChildren; i-- > 0;) {
      const aiNode* child = cur.node->mChildren[i];
      stack.push_back({child, cur.world * child->mTransformation});
    }
  }
}

// PLY headers are checked here before Assimp sees them: Assimp 5.2's PLY parser loops for ever on a header line
// with an unknown keyword (found by tests/fuzz/fuzz_mesh_import.cpp: "prortyep float x"). The grammar: "ply", then
// lines of format / comment / obj_info / element NAME COUNT / property TYPE NAME / property list TYPE TYPE NAME,
// then end_header; at most 64 KiB of header.
std::vector<hw::Triangle> import_isolated(const std::string& path);

void check_ply_header(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  if (!std::getline(in, line)) return;
  // Assimp takes a file for PLY by its extension or by "ply" at its start, whatever follows on that line.
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (line.rfind("ply", 0) != 0 && ext != ".ply") return;
  // Header lines are text. Assimp's PLY reader separates words by ' ' and '\t' only and ends lines at other
  // control characters ('\r', '\f', '\0'), where this check, by std::getline and >>, reads them differently: on
  // "end_header\v0 0 0" Assimp never returned (found by scripts/fuzz_long.sh, regressions/mesh_import/
  // assimp_ply_vertical_tab_after_end_header_hang). So any control character but '\t' (and the '\r' of a CRLF
  // line end) is refused.
  auto check_text = [&](const std::string& text, int n) {
    for (const char c : text) {
      if (static_cast<unsigned char>(c) < 0x20 && c != '\t')
        throw Error(path + ": PLY header line " + std::to_string(n) + ": control character " +
                    std::to_string(int(static_cast<unsigned char>(c))) + " (only spaces and tabs separate words)");
    }
  };
  if (!line.empty() && line.back() == '\r') line.pop_back();
  check_text(line, 1);
  while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
  if (line != "ply") throw Error(path + ": PLY header line 1: expected 'ply'");
  static const std::set<std::string> types = {"char",  "uchar",  "short",   "ushort", "int",   "uint",
                                              "float", "double", "int8",    "uint8",  "int16", "uint16",
                                              "int32", "uint32", "float32", "float64"};
  size_t bytes = line.size() + 1;
  for (int n = 2; std::getline(in, line); ++n) {
    bytes += line.size() + 1;
    if (bytes > 65536) throw Error(path + ": PLY header longer than 64 KiB");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    check_text(line, n);
    std::istringstream words(line);
    std::vector<std::string> w;
    for (std::string x; words >> x;) w.push_back(x);
    auto bad = [&](const std::string& why) {
      throw Error(path + ": PLY header line " + std::to_string(n) + ": " + why + " ('" + line + "')");
    };
    if (w.empty()) bad("empty line");
    const std::string& k = w[0];
    if (k == "end_header") return;
    if (k == "comment" || k == "obj_info") continue;
    if (k == "format") {
      if (w.size() != 3 || (w[1] != "ascii" && w[1] != "binary_little_endian" && w[1] != "binary_big_endian"))
        bad("expected 'format ascii|binary_little_endian|binary_big_endian VERSION'");
    } else if (k == "element") {
      if (w.size() != 3 || w[2].find_first_not_of("0123456789") != std::string::npos)
        bad("expected 'element NAME COUNT'");
    } else if (k == "property") {
      const bool list = w.size() == 5 && w[1] == "list" && types.count(w[2]) && types.count(w[3]);
      if (!list && !(w.size() == 3 && types.count(w[1])))
        bad("expected 'property TYPE NAME' or 'property list TYPE TYPE NAME'");
    } else {
      bad("unknown keyword '" + k + "'");
    }
  }
  throw Error(path + ": PLY header without end_header");
}

}  // namespace

std::vector<hw::Triangle> import_mesh(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw Error(path + ": file not found");
  if (!std::filesystem::is_regular_file(path, ec)) throw Error(path + ": not a regular file");
  // Assimp holds the file and its parsed meshes at once (several times the file's bytes for text formats), then
  // the triangles are copied out: refuse a file that cannot fit before reading it.
  const uint64_t file_bytes = std::filesystem::file_size(path, ec);
  if (!ec)
    check_memory(path + ": importing a " + std::to_string(file_bytes >> 20) + " MiB mesh file", 8 * file_bytes);

  check_ply_header(path);
  return import_isolated(path);
}

namespace {

// The import proper, in the child process of import_isolated().
std::vector<hw::Triangle> import_with_assimp(const std::string& path) {
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_ValidateDataStructure);
  if (!scene && std::string(importer.GetErrorString()).find("contains no faces") != std::string::npos) {
    // Validation rejects a mesh without faces (e.g. an OBJ of bare vertices: a point cloud). Such a mesh just
    // has no triangles; read again without validation, the checks below cover what this code relies on.
    scene = importer.ReadFile(path, aiProcess_Triangulate);
  }
  if (!scene) throw Error(path + ": " + importer.GetErrorString());

  // First pass: count triangles, so a large mesh is allocated once.
  size_t count = 0;
  walk_nodes(*scene, [&](unsigned mesh_index, const aiMatrix4x4&) {
    if (mesh_index >= scene->mNumMeshes)
      throw Error(path + ": node refers to missing mesh " + std::to_string(mesh_index));
    const aiMesh* mesh = scene->mMeshes[mesh_index];
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) count += mesh->mFaces[f].mNumIndices == 3;
  });

  std::vector<hw::Triangle> triangles;
  triangles.reserve(count);
  const aiMatrix4x4 identity;
  walk_nodes(*scene, [&](unsigned mesh_index, const aiMatrix4x4& world) {
    const aiMesh* mesh = scene->mMeshes[mesh_index];
    const bool transform = !(world == identity);  // exact: an identity node keeps the file's bits
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines
      hw::Vec3 v[3];
      for (int k = 0; k < 3; ++k) {
        const unsigned index = face.mIndices[k];
        if (index >= mesh->mNumVertices) {
          throw Error(path + ": " + mesh_label(*scene, mesh_index) + ", face " + std::to_string(f) +
                      ": index out of range (" + std::to_string(index) +
                      " >= " + std::to_string(mesh->mNumVertices) + " vertices)");
        }
        aiVector3D p = mesh->mVertices[index];
        if (transform) p = world * p;
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
          throw Error(path + ": " + mesh_label(*scene, mesh_index) + ", face " + std::to_string(f) + ", vertex " +
                      std::to_string(index) + ": NaN/Inf coordinate " + format_vec(p));
        }
        v[k] = hw::Vec3(p.x, p.y, p.z);
      }
      triangles.push_back({v[0], v[1], v[2]});
    }
  });
  importer.FreeScene();
  return triangles;
}

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
  std::vector<hw::Triangle> triangles;
  std::string error;  // empty: success
};

void run_import(ImportJob& job) {
  try {
    job.triangles = import_with_assimp(job.path);
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
// contradicts its header), hang or leak cannot take rtusim with it. The child sends {status, bytes} and then the
// triangles (status 0) or the error message (status 1); the parent waits at most RTU_IMPORT_TIMEOUT seconds
// (default 300). Found necessary by tests/fuzz/fuzz_mesh_import.cpp (README "Hardening").
std::vector<hw::Triangle> import_isolated(const std::string& path) {
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
    const uint64_t head[2] = {failed ? 1u : 0u,
                              failed ? job.error.size() : job.triangles.size() * sizeof(hw::Triangle)};
    const bool ok =
        write_all(fds[1], head, sizeof head) &&
        write_all(fds[1], failed ? static_cast<const void*>(job.error.data()) : job.triangles.data(), head[1]);
    ::_exit(ok ? 0 : 3);
  }
  ::close(fds[1]);
  std::vector<char> data;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(timeout_s);
  bool timed_out = false;
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      timed_out = true;
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int r = ::poll(&p, 1, int(std::min<int64_t>(left.count(), 1000)));
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) continue;
    char buf[1 << 16];
    const ssize_t n = ::read(fds[0], buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // the child closed its end (exited)
    data.insert(data.end(), buf, buf + n);
  }
  ::close(fds[0]);
  if (timed_out) ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
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
  if (data.size() != sizeof head + head[1] || (head[0] == 0 && head[1] % sizeof(hw::Triangle) != 0))
    throw Error(path + ": the mesh importer (Assimp) sent a truncated answer");
  if (head[0] != 0) throw Error(std::string(data.data() + sizeof head, head[1]));
  std::vector<hw::Triangle> tris(head[1] / sizeof(hw::Triangle));
  if (!tris.empty()) std::memcpy(tris.data(), data.data() + sizeof head, head[1]);
  return tris;
}

}  // namespace

}  // namespace rtu::host

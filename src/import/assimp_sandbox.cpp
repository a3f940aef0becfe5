#include "import/assimp_sandbox.h"

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <thread>
#include <vector>

#include "fskin/core/error.h"

namespace fskin::import_detail {
namespace {

// More nodes than any character has; beyond it a file is refused.
constexpr size_t kMostAssimpNodes = 1'000'000;

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAddressSanitizer = true;  // its shadow memory needs terabytes of address space
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kAddressSanitizer = true;
#else
constexpr bool kAddressSanitizer = false;
#endif
#else
constexpr bool kAddressSanitizer = false;
#endif

// The process's address space now, in bytes (/proc/self/statm's first field).
size_t address_space_bytes() {
  std::ifstream statm("/proc/self/statm");
  size_t pages = 0;
  statm >> pages;
  return pages * static_cast<size_t>(sysconf(_SC_PAGESIZE));
}

// The child: read, check, report. Writes at most one short message to `fd`
// and leaves with _exit (no destructors of the parent's objects run twice).
[[noreturn]] void run_child(const std::string& path, const ImportOptions& options, int fd) {
  const auto report = [fd](const std::string& message, int code) {
    const std::string m = message.substr(0, 2000);
    if (!m.empty() && ::write(fd, m.data(), m.size()) < 0) code = 3;
    ::_exit(code);
  };
  if (!kAddressSanitizer) {
    const auto limit = address_space_bytes() + static_cast<size_t>(options.assimp_memory_mib) * 1024 * 1024;
    const rlimit bytes{limit, limit};
    setrlimit(RLIMIT_AS, &bytes);
  }
  try {
    Assimp::Importer importer;
    configure_assimp(importer);
    const aiScene* scene = importer.ReadFile(path, assimp_read_flags());
    if (!scene || !scene->mRootNode) report(fmt::format("cannot read it: {}", importer.GetErrorString()), 2);
    check_assimp_scene(scene, path);
  } catch (const Error& e) {
    report(std::string("!") + e.what(), 2);  // '!': a complete message, passed on as is
  } catch (const std::bad_alloc&) {
    report(fmt::format("assimp ran out of its {} MiB memory budget reading it", options.assimp_memory_mib), 2);
  } catch (const std::exception& e) {
    report(fmt::format("assimp failed reading it: {}", e.what()), 2);
  }
  report("", 0);
}

}  // namespace

unsigned assimp_read_flags() { return aiProcess_Triangulate | aiProcess_SortByPType; }

void configure_assimp(Assimp::Importer& importer) {
  // Pivot helper nodes ($AssimpFbx$_...) would become joints of their own.
  importer.SetPropertyBool(AI_CONFIG_IMPORT_FBX_PRESERVE_PIVOTS, false);
  // A skin's bones without weights are still joints the clips move.
  importer.SetPropertyBool(AI_CONFIG_IMPORT_REMOVE_EMPTY_BONES, false);
}

void probe_with_assimp(const std::string& path, const ImportOptions& options) {
  FSKIN_CHECK(options.assimp_seconds > 0 && options.assimp_memory_mib > 0,
              "{}: the assimp budget must be positive ({} s, {} MiB)", path, options.assimp_seconds,
              options.assimp_memory_mib);
  int pipe_fds[2];
  FSKIN_CHECK(::pipe(pipe_fds) == 0, "{}: cannot create a pipe for assimp's reader: {}", path, std::strerror(errno));
  std::fflush(nullptr);
  const pid_t child = ::fork();
  if (child < 0) {
    ::close(pipe_fds[0]);
    ::close(pipe_fds[1]);
    fail("{}: cannot start assimp's reader process: {}", path, std::strerror(errno));
  }
  if (child == 0) {
    ::close(pipe_fds[0]);
    run_child(path, options, pipe_fds[1]);
  }
  ::close(pipe_fds[1]);
  // Collect the message while waiting (the child writes at most 2 KB, below a
  // pipe's buffer, so it never blocks), killing the child past its time.
  std::string message;
  const auto start = std::chrono::steady_clock::now();
  int status = 0;
  bool timed_out = false;
  for (;;) {
    pollfd readable{pipe_fds[0], POLLIN, 0};
    if (::poll(&readable, 1, 20) > 0) {
      char buffer[512];
      const ssize_t n = ::read(pipe_fds[0], buffer, sizeof buffer);
      if (n > 0) message.append(buffer, static_cast<size_t>(n));
    }
    const pid_t done = ::waitpid(child, &status, WNOHANG);
    if (done == child) break;
    if (done < 0 && errno != EINTR) break;
    const std::chrono::duration<double> elapsed = std::chrono::steady_clock::now() - start;
    if (elapsed.count() > options.assimp_seconds) {
      ::kill(child, SIGKILL);
      ::waitpid(child, &status, 0);
      timed_out = true;
      break;
    }
  }
  for (char buffer[512];;) {
    const ssize_t n = ::read(pipe_fds[0], buffer, sizeof buffer);
    if (n <= 0) break;
    message.append(buffer, static_cast<size_t>(n));
  }
  ::close(pipe_fds[0]);
  FSKIN_CHECK(!timed_out, "{}: assimp did not finish reading it within {:g} s (ImportOptions::assimp_seconds)", path,
              options.assimp_seconds);
  if (WIFSIGNALED(status))
    fail("{}: assimp crashed reading it (signal {}: {}); the file is malformed or beyond what assimp reads", path,
         WTERMSIG(status), strsignal(WTERMSIG(status)));
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
  if (!message.empty() && message[0] == '!') throw Error(message.substr(1));
  fail("{}: {}", path,
       message.empty() ? fmt::format("assimp's reader ended with status {} (out of its {} MiB memory budget?)",
                                     WIFEXITED(status) ? WEXITSTATUS(status) : -1, options.assimp_memory_mib)
                       : message);
}

void check_assimp_scene(const aiScene* scene, const std::string& path) {
  FSKIN_CHECK(scene && scene->mRootNode, "{}: assimp returned no scene", path);
  FSKIN_CHECK(scene->mNumMeshes == 0 || scene->mMeshes, "{}: the scene lists {} meshes but holds none", path,
              scene->mNumMeshes);
  // Nodes, breadth-first with an explicit queue (a chain may be as deep as
  // the file has nodes).
  std::vector<const aiNode*> queue{scene->mRootNode};
  for (size_t i = 0; i < queue.size(); ++i) {
    const aiNode* node = queue[i];
    FSKIN_CHECK(node->mNumChildren == 0 || node->mChildren, "{}: node '{}' lists {} children but holds none", path,
                node->mName.C_Str(), node->mNumChildren);
    FSKIN_CHECK(node->mNumMeshes == 0 || node->mMeshes, "{}: node '{}' lists {} meshes but holds none", path,
                node->mName.C_Str(), node->mNumMeshes);
    for (unsigned k = 0; k < node->mNumMeshes; ++k)
      FSKIN_CHECK(node->mMeshes[k] < scene->mNumMeshes && scene->mMeshes[node->mMeshes[k]],
                  "{}: node '{}' refers to mesh {} of {}", path, node->mName.C_Str(), node->mMeshes[k],
                  scene->mNumMeshes);
    for (unsigned c = 0; c < node->mNumChildren; ++c) {
      FSKIN_CHECK(node->mChildren[c], "{}: node '{}' has a missing child", path, node->mName.C_Str());
      queue.push_back(node->mChildren[c]);
    }
    FSKIN_CHECK(queue.size() <= kMostAssimpNodes, "{}: more than {} nodes (or a cycle in the node tree)", path,
                kMostAssimpNodes);
  }
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* mesh = scene->mMeshes[m];
    if (!mesh) continue;  // nodes referring to it were refused above
    const char* name = mesh->mName.C_Str();
    FSKIN_CHECK(mesh->mNumVertices == 0 || mesh->mVertices, "{}: mesh '{}' has no vertex array", path, name);
    FSKIN_CHECK(mesh->mNumFaces == 0 || mesh->mFaces, "{}: mesh '{}' has no face array", path, name);
    FSKIN_CHECK(mesh->mNumBones == 0 || mesh->mBones, "{}: mesh '{}' has no bone array", path, name);
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      FSKIN_CHECK(face.mNumIndices == 0 || face.mIndices, "{}: mesh '{}' face {} has no indices", path, name, f);
      for (unsigned k = 0; k < face.mNumIndices; ++k)
        FSKIN_CHECK(face.mIndices[k] < mesh->mNumVertices, "{}: mesh '{}' face {} refers to vertex {} of {}", path,
                    name, f, face.mIndices[k], mesh->mNumVertices);
    }
    for (unsigned b = 0; b < mesh->mNumBones; ++b) {
      const aiBone* bone = mesh->mBones[b];
      FSKIN_CHECK(bone, "{}: mesh '{}' has a missing bone", path, name);
      FSKIN_CHECK(bone->mNumWeights == 0 || bone->mWeights, "{}: bone '{}' of mesh '{}' has no weight array", path,
                  bone->mName.C_Str(), name);
    }
  }
  FSKIN_CHECK(scene->mNumAnimations == 0 || scene->mAnimations, "{}: the scene lists {} animations but holds none",
              path, scene->mNumAnimations);
  for (unsigned a = 0; a < scene->mNumAnimations; ++a) {
    const aiAnimation* animation = scene->mAnimations[a];
    FSKIN_CHECK(animation, "{}: animation {} is missing", path, a);
    FSKIN_CHECK(animation->mNumChannels == 0 || animation->mChannels, "{}: animation {} has no channel array", path,
                a);
    for (unsigned c = 0; c < animation->mNumChannels; ++c) {
      const aiNodeAnim* channel = animation->mChannels[c];
      FSKIN_CHECK(channel, "{}: animation {} has a missing channel", path, a);
      FSKIN_CHECK((channel->mNumPositionKeys == 0 || channel->mPositionKeys) &&
                      (channel->mNumRotationKeys == 0 || channel->mRotationKeys) &&
                      (channel->mNumScalingKeys == 0 || channel->mScalingKeys),
                  "{}: animation {} channel '{}' has a missing key array", path, a, channel->mNodeName.C_Str());
    }
  }
}

}  // namespace fskin::import_detail

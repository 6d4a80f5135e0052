#include "self_exec.h"

#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

#include "test_paths.h"
#include "test_pki.h"

namespace shapesense::testing {

namespace fs = std::filesystem;

std::optional<fs::path> fakenectLibraryDir() {
  for (const char* dir :
       {"/usr/lib/x86_64-linux-gnu/fakenect", "/usr/lib/aarch64-linux-gnu/fakenect",
        "/usr/lib/arm-linux-gnueabihf/fakenect", "/usr/lib/fakenect"}) {
    if (fs::exists(fs::path(dir) / "libfreenect.so.0.5")) return fs::path(dir);
  }
  return std::nullopt;
}

std::pair<int, std::string> runSelf(const std::string& filter, const std::vector<std::string>& env,
                                    const fs::path& log, std::chrono::seconds limit) {
  const fs::path self = fs::read_symlink("/proc/self/exe");
  const pid_t pid = fork();
  if (pid == 0) {
    for (const auto& assignment : env) putenv(const_cast<char*>(assignment.c_str()));
    std::FILE* out = std::freopen(log.c_str(), "w", stdout);
    if (out == nullptr || dup2(fileno(stdout), STDERR_FILENO) < 0) _exit(126);
    const std::string filter_arg = "--gtest_filter=" + filter;
    execl(self.c_str(), self.c_str(), filter_arg.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  int status = 0;
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      status = -1;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  const int code =
      status == -1 ? -1 : (WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status));
  return {code, text.str()};
}

std::vector<std::string> fakenectEnvironment(const fs::path& library_dir, const fs::path& dump,
                                             const std::string& inner_flag) {
  std::string asan = "ASAN_OPTIONS=detect_leaks=0";  // fakenect's own allocations at exit
  if (const char* existing = std::getenv("ASAN_OPTIONS"))
    asan = std::string("ASAN_OPTIONS=") + existing + ":detect_leaks=0";
  const char* ld_path = std::getenv("LD_LIBRARY_PATH");
  return {inner_flag + "=1", "FAKENECT_PATH=" + dump.string(),
          "LD_LIBRARY_PATH=" + library_dir.string() + (ld_path ? std::string(":") + ld_path : ""),
          asan};
}

std::pair<int, std::string> runCommand(const std::string& command, const fs::path& log) {
  const int status = std::system((command + " >'" + log.string() + "' 2>&1").c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, readText(log)};
}

std::pair<int, std::string> runShapesensed(const std::string& arguments, int seconds) {
  const fs::path binary = fs::path(SHAPESENSE_BINARY_DIR) / "server" / "shapesensed";
  const fs::path dir =
      scratchDir("shapesensed-run-" +
                 std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
  return runCommand("timeout " + std::to_string(seconds) + " '" + binary.string() + "' " +
                        arguments + " --record-root '" + (dir / "recordings").string() +
                        "' --object-models '" + (dir / "object-models").string() + "'",
                    dir / "out.txt");
}

}  // namespace shapesense::testing

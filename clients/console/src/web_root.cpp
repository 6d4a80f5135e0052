#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>

#include "shapesense/console/console_server.h"

namespace shapesense::console {
namespace {

bool holdsPage(const std::filesystem::path& dir) {
  std::error_code error;
  return std::filesystem::is_regular_file(dir / "index.html", error);
}

}  // namespace

std::filesystem::path defaultWebRoot() {
  std::error_code error;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    const auto beside = exe.parent_path().parent_path() / "share" / "shapesense" / "web";
    if (holdsPage(beside)) return beside;
  }
  const std::filesystem::path installed = SHAPESENSE_INSTALLED_WEB_DIR;
  if (holdsPage(installed)) return installed;
  return SHAPESENSE_SOURCE_WEB_DIR;
}

bool isLoopbackListen(const std::string& listen) {
  const auto colon = listen.rfind(':');
  std::string host = listen.substr(0, colon == std::string::npos ? listen.size() : colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']')
    host = host.substr(1, host.size() - 2);
  std::transform(host.begin(), host.end(), host.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return host == "localhost" || host == "::1" || host.starts_with("127.");
}

}  // namespace shapesense::console

#pragma once
// Locations of test data. shared/ (real recordings) sits beside the repository.

#include <cstdlib>
#include <filesystem>
#include <string>

namespace shapesense::testing {

/// The project's shared/ folder: $SHAPESENSE_SHARED_DIR, else the one found at configure time.
inline std::filesystem::path sharedDir() {
  if (const char* env = std::getenv("SHAPESENSE_SHARED_DIR")) return env;
  return SHAPESENSE_SHARED_DIR;
}

/// shared/data/real/<name>: a real Kinect-class recording in the TUM layout.
inline std::filesystem::path realRecording(const std::string& name) {
  return sharedDir() / "data" / "real" / name;
}

/// A fresh empty directory under the build tree for one test's output.
inline std::filesystem::path scratchDir(const std::string& name) {
  auto dir = std::filesystem::path(SHAPESENSE_BINARY_DIR) / "test-scratch" / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace shapesense::testing

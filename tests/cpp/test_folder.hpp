// A fresh temporary folder for the running test, removed at its end.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

namespace tqtest {

/// A folder of the running test's own (`prefix`, the process id and the test's name under the
/// system's temporary folder), removed with all in it when the object goes; f / "name" is the path
/// of a file in it.
struct TestFolder {
  std::filesystem::path dir;
  explicit TestFolder(const std::string& prefix) {
    dir = std::filesystem::temp_directory_path() /
          (prefix + std::to_string(::getpid()) + "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir);
  }
  ~TestFolder() { std::filesystem::remove_all(dir); }
  TestFolder(const TestFolder&) = delete;
  TestFolder& operator=(const TestFolder&) = delete;
  std::string operator/(const std::string& n) const { return (dir / n).string(); }
};

}  // namespace tqtest

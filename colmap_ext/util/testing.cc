#include "colmap_ext/util/testing.h"

#include "colmap/util/logging.h"

#include <boost/filesystem.hpp>
#include <gtest/gtest.h>

namespace colmap {

std::string CreateTestDir() {
  const testing::TestInfo* test_info =
      THROW_CHECK_NOTNULL(testing::UnitTest::GetInstance()->current_test_info());
  const boost::filesystem::path test_dir =
      boost::filesystem::path(testing::TempDir()) / "colmap_ext_tests" /
      (std::string(test_info->test_suite_name()) + "." + test_info->name());
  boost::filesystem::remove_all(test_dir);
  boost::filesystem::create_directories(test_dir);
  return test_dir.string();
}

}  // namespace colmap

// H5File::soft_link: a link at an old path reads the same data as its target (results.h5
// keeps a renamed group's old names as links, src/edmd/driver.cpp), and a link to a missing
// object is refused rather than left dangling.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <stdexcept>

#include "core/h5.hpp"

using namespace grainbath;

namespace {
std::string temp_file(const char* tag) {
  return (std::filesystem::temp_directory_path() / (std::string("h5_test_") + tag + "_" + std::to_string(::getpid()) + ".h5"))
      .string();
}
}  // namespace

TEST(H5File, SoftLinkReadsTheTargetsData) {
  const std::string path = temp_file("link");
  const std::vector<double> t{0.0, 0.5, 1.25};
  {
    H5File f(path, H5File::Mode::create);
    f.write("/new/t", t);
    f.soft_link("/old/time", "/new/t");  // creates the group /old
    f.write("/new/x", std::vector<double>{7.0});
    f.soft_link("/old/time", "/new/x");  // replaces the earlier link
    f.soft_link("/old/time", "/new/t");
    f.close();
  }
  H5File f(path, H5File::Mode::read);
  EXPECT_TRUE(f.exists("/old/time"));
  EXPECT_EQ(f.read_doubles("/old/time"), t);
  EXPECT_EQ(f.length("/old/time"), t.size());
  EXPECT_EQ(f.soft_link_target("/old/time"), "/new/t");
  EXPECT_EQ(f.soft_link_target("/new/t"), "");    // a dataset, not a link
  EXPECT_EQ(f.soft_link_target("/old/none"), "");  // missing
  std::filesystem::remove(path);
}

TEST(H5File, SoftLinkToAMissingObjectIsRefused) {
  const std::string path = temp_file("dangling");
  {
    H5File f(path, H5File::Mode::create);
    f.write("/new/t", std::vector<double>{1.0});
    EXPECT_THROW(f.soft_link("/old/time", "/new/time"), std::runtime_error);
    EXPECT_FALSE(f.exists("/old/time"));
    f.close();
  }
  std::filesystem::remove(path);
}

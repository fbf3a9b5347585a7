// H5File::soft_link: a link at an old path reads the same data as its target (results.h5
// keeps a renamed group's old names as links, src/edmd/driver.cpp), and a link to a missing
// object is refused rather than left dangling.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <stdexcept>
#include <thread>

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

// ---- the writer's contract (docs/OUTPUT.md's shapes and types; the h5/XDMF/commands mutation
// audit, docs/reviews/mutation-audit-h5-xdmf-commands.md), read back through the HDF5 C API
// rather than through H5File's own readers, which would convert a wrong type silently.
namespace {

struct Scratch {  // a file name, removed at the end
  std::string path;
  explicit Scratch(const char* tag) : path(temp_file(tag)) { std::filesystem::remove(path); }
  ~Scratch() { std::filesystem::remove(path); }
};

// The shape, type class, size and sign of a dataset (C API)
struct Layout {
  std::vector<hsize_t> dims;
  H5T_class_t type_class = H5T_NO_CLASS;
  std::size_t size = 0;
  H5T_sign_t sign = H5T_SGN_ERROR;
  H5T_str_t pad = H5T_STR_ERROR;
};
Layout layout_of(hid_t object, bool attribute) {
  Layout l;
  const hid_t space = attribute ? H5Aget_space(object) : H5Dget_space(object);
  const hid_t type = attribute ? H5Aget_type(object) : H5Dget_type(object);
  const int rank = H5Sget_simple_extent_ndims(space);
  l.dims.resize(rank > 0 ? rank : 0);
  if (rank > 0) H5Sget_simple_extent_dims(space, l.dims.data(), nullptr);
  l.type_class = H5Tget_class(type);
  l.size = H5Tget_size(type);
  if (l.type_class == H5T_INTEGER) l.sign = H5Tget_sign(type);
  if (l.type_class == H5T_STRING) l.pad = H5Tget_strpad(type);
  H5Tclose(type);
  H5Sclose(space);
  return l;
}
Layout dataset_layout(const std::string& path, const std::string& name) {
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t ds = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
  Layout l = ds >= 0 ? layout_of(ds, false) : Layout{};
  if (ds >= 0) H5Dclose(ds);
  H5Fclose(file);
  return l;
}
Layout attribute_layout(const std::string& path, const std::string& object, const std::string& name,
                        std::string* raw = nullptr) {
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t a = H5Aopen_by_name(file, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT);
  Layout l = a >= 0 ? layout_of(a, true) : Layout{};
  if (a >= 0 && raw) {  // the stored bytes of a string attribute
    const hid_t type = H5Aget_type(a);
    hsize_t n = 1;
    for (hsize_t d : l.dims) n *= d;
    raw->assign(n * l.size, '\0');
    H5Aread(a, type, raw->data());
    H5Tclose(type);
  }
  if (a >= 0) H5Aclose(a);
  H5Fclose(file);
  return l;
}
std::string bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace

// Datasets keep the shape and type they are written with: 1D of the data's length unless
// dims are given, 8-byte floats, unsigned and signed 64-bit integers; the scalars of
// docs/OUTPUT.md are arrays of shape (1,) (e.g. /mode/decay_rate), an integer one exact beyond
// 2^53; read_doubles returns the shape.
TEST(H5File, DatasetsHaveTheShapesAndTypesTheyAreWrittenWith) {
  Scratch s("layout");
  const std::uint64_t big = (std::uint64_t{1} << 53) + 1;  // not a double
  {
    H5File f(s.path, H5File::Mode::create);
    f.write("/a/line", std::vector<double>{1, 2, 3, 4, 5, 6});
    f.write("/a/grid", std::vector<double>{1, 2, 3, 4, 5, 6}, {2, 3});
    f.write("/b/counts", std::vector<std::uint64_t>{big, 2});  // /b made for it
    f.write("/b/signed", std::vector<std::int64_t>{-5, 7});
    f.write_scalar("/c/x", 0.1);
    f.write_scalar("/c/n", big);
    f.close();
  }
  const Layout line = dataset_layout(s.path, "/a/line"), grid = dataset_layout(s.path, "/a/grid"),
               counts = dataset_layout(s.path, "/b/counts"), sgn = dataset_layout(s.path, "/b/signed"),
               x = dataset_layout(s.path, "/c/x"), n = dataset_layout(s.path, "/c/n");
  EXPECT_EQ(line.dims, (std::vector<hsize_t>{6}));
  EXPECT_EQ(grid.dims, (std::vector<hsize_t>{2, 3}));
  for (const Layout* l : {&line, &grid, &x}) {
    EXPECT_EQ(l->type_class, H5T_FLOAT);
    EXPECT_EQ(l->size, 8u);
  }
  EXPECT_EQ(counts.type_class, H5T_INTEGER);
  EXPECT_EQ(counts.size, 8u);
  EXPECT_EQ(counts.sign, H5T_SGN_NONE);
  EXPECT_EQ(sgn.type_class, H5T_INTEGER);
  EXPECT_EQ(sgn.size, 8u);
  EXPECT_EQ(sgn.sign, H5T_SGN_2);
  EXPECT_EQ(x.dims, (std::vector<hsize_t>{1}));
  EXPECT_EQ(n.dims, (std::vector<hsize_t>{1}));
  EXPECT_EQ(n.type_class, H5T_INTEGER);
  EXPECT_EQ(n.sign, H5T_SGN_NONE);
  H5File f(s.path, H5File::Mode::read);
  std::vector<hsize_t> dims;
  EXPECT_EQ(f.read_doubles("/a/grid", &dims), (std::vector<double>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(dims, (std::vector<hsize_t>{2, 3}));
  EXPECT_EQ(f.read_u64("/b/counts"), (std::vector<std::uint64_t>{big, 2}));
  EXPECT_EQ(f.read_i64("/b/signed"), (std::vector<std::int64_t>{-5, 7}));
  EXPECT_EQ(f.read_scalar("/c/x"), 0.1);
  EXPECT_EQ(f.read_scalar_u64("/c/n"), big);
  EXPECT_TRUE(f.exists("/b/counts"));
  EXPECT_FALSE(f.exists("/b/none"));
  EXPECT_FALSE(f.exists("/none/x"));
}

// Strings and attributes: fixed-length null-padded strings of the text's length (an empty one
// reads back empty), 8-byte float and signed 64-bit integer attributes, integer arrays
// (H5MD's version [1, 1]) and string arrays padded to the longest (H5MD's box boundary); an
// attribute on an existing dataset; attribute_names in name order; a string attribute is no
// integer. Writing any of them again replaces it.
TEST(H5File, StringsAndAttributesAreStoredAsWrittenAndReplaced) {
  Scratch s("attributes");
  const std::int64_t large = (std::int64_t{1} << 40) + 3;
  {
    H5File f(s.path, H5File::Mode::create);
    f.write_string("/case/text", "old text that is longer");
    f.write_string("/case/text", "a = 1");
    f.write_string("/case/empty", "");
    f.write("/data/t", std::vector<double>{1, 2});
    f.write("/data/t", std::vector<double>{3, 4, 5});  // replaced, with a new length
    f.attribute("/data/t", "units", std::string("old"));
    f.attribute("/data/t", "units", std::string("tau"));  // on a dataset, replaced
    f.attribute("/data", "ratio", 0.5);
    f.attribute("/data", "ratio", 0.1);
    f.attribute("/data", "count", std::int64_t{1});
    f.attribute("/data", "count", large);
    f.attribute("/data", "offset", std::int64_t{-3});
    f.attribute("/h5md", "version", std::vector<std::int64_t>{1, 1});
    f.attribute("/box", "boundary", std::vector<std::string>{"none", "periodic", "x"});  // the longest not first
    f.close();
  }
  const Layout text = dataset_layout(s.path, "/case/text");
  EXPECT_EQ(text.type_class, H5T_STRING);
  EXPECT_EQ(text.size, 5u);
  EXPECT_EQ(text.pad, H5T_STR_NULLPAD);
  EXPECT_TRUE(text.dims.empty());  // a scalar
  const Layout units = attribute_layout(s.path, "/data/t", "units");
  EXPECT_EQ(units.size, 3u);
  EXPECT_EQ(units.pad, H5T_STR_NULLPAD);
  const Layout ratio = attribute_layout(s.path, "/data", "ratio");
  EXPECT_EQ(ratio.type_class, H5T_FLOAT);
  EXPECT_EQ(ratio.size, 8u);
  const Layout count = attribute_layout(s.path, "/data", "count");
  EXPECT_EQ(count.type_class, H5T_INTEGER);
  EXPECT_EQ(count.size, 8u);
  EXPECT_EQ(count.sign, H5T_SGN_2);
  const Layout version = attribute_layout(s.path, "/h5md", "version");
  EXPECT_EQ(version.dims, (std::vector<hsize_t>{2}));
  EXPECT_EQ(version.size, 8u);
  std::string raw;
  const Layout boundary = attribute_layout(s.path, "/box", "boundary", &raw);
  EXPECT_EQ(boundary.dims, (std::vector<hsize_t>{3}));
  EXPECT_EQ(boundary.size, 8u);  // "periodic"
  EXPECT_EQ(raw, std::string("none\0\0\0\0", 8) + std::string("periodic") + std::string("x\0\0\0\0\0\0\0", 8));

  H5File f(s.path, H5File::Mode::read);
  EXPECT_EQ(f.read_string("/case/text"), "a = 1");
  EXPECT_EQ(f.read_string("/case/empty"), "");
  EXPECT_EQ(f.read_attribute("/data/t", "units"), "tau");
  EXPECT_EQ(f.read_doubles("/data/t"), (std::vector<double>{3, 4, 5}));
  EXPECT_EQ(f.read_int_attribute("/data", "count"), large);
  EXPECT_EQ(f.read_int_attribute("/data", "offset"), -3);
  // a string or a floating-point attribute is no integer (HDF5 would truncate 0.1 to 0)
  for (const auto& [object, name] : {std::pair{"/data/t", "units"}, std::pair{"/data", "ratio"}}) {
    try {
      f.read_int_attribute(object, name);
      ADD_FAILURE() << name << " read as an integer";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(std::string(object) + "@" + name + " is not a scalar integer"),
                std::string::npos)
          << e.what();
    }
  }
  EXPECT_EQ(f.attribute_names("/data"), (std::vector<std::string>{"count", "offset", "ratio"}));
  const hid_t a = H5Aopen_by_name(H5Fopen(s.path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), "/data", "ratio", H5P_DEFAULT,
                                  H5P_DEFAULT);
  double r = 0;
  H5Aread(a, H5T_NATIVE_DOUBLE, &r);
  EXPECT_EQ(r, 0.1);  // all of its 53 bits
  std::int64_t v[2] = {0, 0};
  const hid_t file = H5Fopen(s.path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t va = H5Aopen_by_name(file, "/h5md", "version", H5P_DEFAULT, H5P_DEFAULT);
  H5Aread(va, H5T_NATIVE_INT64, v);
  EXPECT_EQ(v[0], 1);
  EXPECT_EQ(v[1], 1);
  H5Aclose(va);
  H5Aclose(a);
  H5Fclose(file);
}

// One process's parts of a 1D dataset (write_slab, the checkpoints' particle arrays): the
// parts land at their offsets, a part beyond the dataset is refused, and the file is byte for
// byte the one written whole (the checkpoint's "same file at any process count"), also when
// its creator had no part and another process adds the parts later (Mode::update). Elements
// read back by range (read_doubles_slab: the chunked checkpoint reader).
TEST(H5File, SlabsLandAtTheirOffsetsAndTheFileIsTheOneWrittenWhole) {
  const std::vector<double> whole{0.5, 1.5, 2.5, 3.5, 4.5, 5.5, 6.5};
  const std::vector<double> head(whole.begin(), whole.begin() + 3), tail(whole.begin() + 3, whole.end());
  Scratch a("whole"), b("parts"), c("later");
  {
    H5File f(a.path, H5File::Mode::create);
    f.write("/p/x", whole);
    f.write("/p/n", std::vector<std::uint64_t>{7});
    f.close();
  }
  {
    H5File f(b.path, H5File::Mode::create);
    f.write_slab("/p/x", head, whole.size(), 0);
    f.write_slab("/p/x", tail, whole.size(), 3);
    EXPECT_THROW(f.write_slab("/p/x", tail, whole.size(), 4), std::logic_error);
    f.write("/p/n", std::vector<std::uint64_t>{7});
    f.close();
  }
  {
    H5File f(c.path, H5File::Mode::create);
    f.write_slab("/p/x", std::vector<double>{}, whole.size(), 0);  // the creator's part is empty
    f.write("/p/n", std::vector<std::uint64_t>{7});
    f.close();
    H5File g(c.path, H5File::Mode::update);
    g.write_slab("/p/x", head, whole.size(), 0);
    g.write_slab("/p/x", tail, whole.size(), 3);
    g.close();
  }
  H5File f(b.path, H5File::Mode::read);
  EXPECT_EQ(f.read_doubles("/p/x"), whole);
  EXPECT_EQ(f.read_doubles_slab("/p/x", 2, 3), (std::vector<double>{2.5, 3.5, 4.5}));
  EXPECT_EQ(f.length("/p/x"), whole.size());
  EXPECT_THROW(f.read_doubles_slab("/p/x", 5, 3), std::runtime_error);
  EXPECT_EQ(H5File(c.path, H5File::Mode::read).read_doubles("/p/x"), whole);
  EXPECT_TRUE(bytes_of(b.path) == bytes_of(a.path)) << "the file written in parts differs from the one written whole";
  // the creator without a part allocated the array where it stands in the file written whole,
  // ahead of what the creator wrote after it (not at the end, at the first part's write)
  const auto data_offset = [](const std::string& path, const char* name) {
    const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    const hid_t ds = H5Dopen2(file, name, H5P_DEFAULT);
    const haddr_t at = H5Dget_offset(ds);
    H5Dclose(ds);
    H5Fclose(file);
    return at;
  };
  EXPECT_LT(data_offset(c.path, "/p/x"), data_offset(c.path, "/p/n"));
  EXPECT_LT(data_offset(a.path, "/p/x"), data_offset(a.path, "/p/n"));
}

// The same content written a second later is the same bytes (no modification times in the
// objects' headers: a run's results.h5 is a function of its case and seed).
TEST(H5File, TheSameContentALaterSecondIsTheSameBytes) {
  Scratch a("first"), b("second");
  const auto write = [](const std::string& path) {
    H5File f(path, H5File::Mode::create);
    f.write("/g/x", std::vector<double>{1, 2});
    f.write_string("/g/s", "text");
    f.attribute("/g", "a", 1.0);
    f.close();
  };
  write(a.path);
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));  // HDF5's times are in seconds
  write(b.path);
  EXPECT_EQ(bytes_of(a.path), bytes_of(b.path));
}

// Errors name the file and why: a missing file, a directory, a file that is not HDF5; a
// missing dataset (the reader's message starts with the file's path).
TEST(H5File, ErrorsNameTheFileAndTheReason) {
  Scratch s("errors");
  const std::string dir = s.path + ".d", text = s.path + ".txt";
  std::filesystem::create_directories(dir);
  { std::ofstream(text) << "not hdf5\n"; }
  const auto message = [](const std::string& path, H5File::Mode mode) {
    try {
      H5File f(path, mode);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message(s.path, H5File::Mode::read), s.path + ": cannot open HDF5 file (no such file)");
  EXPECT_EQ(message(dir, H5File::Mode::read), dir + ": cannot open HDF5 file (a directory)");
  EXPECT_EQ(message(text, H5File::Mode::update), text + ": cannot open for writing HDF5 file (not an HDF5 file)");
  {
    H5File f(s.path, H5File::Mode::create);
    f.write("/x", std::vector<double>{1});
    f.close();
  }
  H5File f(s.path, H5File::Mode::read);
  for (const auto& read : std::vector<std::function<void()>>{[&] { f.read_string("/none"); },
                                                             [&] { f.read_attribute("/x", "none"); },
                                                             [&] { f.length("/none"); }}) {
    try {
      read();
      ADD_FAILURE() << "no error";
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()).rfind(s.path + ": missing ", 0), 0u) << e.what();
    }
  }
  std::filesystem::remove_all(dir);
  std::filesystem::remove(text);
}

// A dataset whose data cannot be written (a full disk: here a file-size limit in a child
// process, SIGXFSZ ignored, as a full disk sends no signal) is an error naming that dataset
// when it is written, not only later at the file's close. Small data are held by HDF5 until
// the dataset is closed, so that close is checked too.
TEST(H5File, ADatasetThatCannotBeWrittenIsAnErrorNamingIt) {
  Scratch s("full");
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::signal(SIGXFSZ, SIG_IGN);
    const rlimit limit{4096, 4096};
    if (::setrlimit(RLIMIT_FSIZE, &limit) != 0) ::_exit(3);
    int code = 1;  // no error
    try {
      H5File f(s.path, H5File::Mode::create);
      f.write("/big", std::vector<double>(1024, 1.0));  // 8 KB
    } catch (const std::runtime_error& e) {
      code = std::string(e.what()) == s.path + ": cannot write dataset /big (disk full?)" ? 0 : 2;
    }
    ::_exit(code);  // not exit(): HDF5's clean-up of a failed file is not under test
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << "the writer died of signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 0) << "1: no error at the write; 2: another message; 3: no limit";
}

#include "core/h5.hpp"

#include <algorithm>
#include <filesystem>
#include <stdexcept>

namespace grainbath {

namespace {
struct SilenceHdf5 {
  SilenceHdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }
};
const SilenceHdf5 silence_hdf5;

// Object creation property lists without modification times, so that the same run writes
// a bitwise identical file (HDF5 stores times in object headers by default).
hid_t untimed(hid_t cls) {
  hid_t p = H5Pcreate(cls);
  H5Pset_obj_track_times(p, false);
  return p;
}
hid_t dataset_plist() {
  static const hid_t p = untimed(H5P_DATASET_CREATE);
  return p;
}
// A dataset that several processes fill in turn, created by one that has no part of it:
// contiguous storage allocated at creation (by default it is allocated at the first write,
// which would then put the array at the end of the file, after everything the creator
// wrote); no fill values are written (none is set).
hid_t early_dataset_plist() {
  static const hid_t p = [] {
    hid_t q = untimed(H5P_DATASET_CREATE);
    H5Pset_alloc_time(q, H5D_ALLOC_TIME_EARLY);
    return q;
  }();
  return p;
}
hid_t group_plist() {
  static const hid_t p = untimed(H5P_GROUP_CREATE);
  return p;
}

struct Handle {  // closes any HDF5 id on scope exit
  hid_t id;
  herr_t (*closer)(hid_t);
  ~Handle() {
    if (id >= 0) closer(id);
  }
};
}  // namespace

H5File::H5File(const std::string& path, Mode mode) : path_(path) {
  if (mode == Mode::create)
    file_ = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  else
    file_ = H5Fopen(path.c_str(), mode == Mode::update ? H5F_ACC_RDWR : H5F_ACC_RDONLY, H5P_DEFAULT);
  if (file_ < 0) {
    // which of the usual reasons (review 4: a missing file and a text file both read "cannot
    // open HDF5 file")
    std::error_code ec;
    std::string why;
    if (mode != Mode::create && !std::filesystem::exists(path, ec))
      why = " (no such file)";
    else if (mode != Mode::create && std::filesystem::is_directory(path, ec))
      why = " (a directory)";
    else if (mode != Mode::create && H5Fis_hdf5(path.c_str()) <= 0)
      why = " (not an HDF5 file)";
    throw std::runtime_error(path + ": cannot " + (mode == Mode::create ? "create" : mode == Mode::update ? "open for writing" : "open") +
                             " HDF5 file" + why);
  }
}

H5File::~H5File() {
  if (file_ >= 0) H5Fclose(file_);
}

void H5File::fail(const std::string& what) const { throw std::runtime_error(path_ + ": " + what); }

void H5File::close() {
  if (file_ < 0) return;
  const herr_t f = H5Fflush(file_, H5F_SCOPE_GLOBAL);
  const herr_t c = H5Fclose(file_);
  file_ = -1;
  if (f < 0 || c < 0) fail("write failed (disk full?)");
}

bool H5File::exists(const std::string& name) const {
  // Walk the path so a missing intermediate group is not an error.
  std::string sofar;
  std::size_t pos = 0;
  while (pos < name.size()) {
    std::size_t next = name.find('/', pos + 1);
    sofar = name.substr(0, next == std::string::npos ? name.size() : next);
    if (!sofar.empty() && sofar != "/" && H5Lexists(file_, sofar.c_str(), H5P_DEFAULT) <= 0) return false;
    if (next == std::string::npos) break;
    pos = next;
  }
  return true;
}

hid_t H5File::ensure_group(const std::string& name) {
  if (name.empty() || name == "/") return H5Gopen2(file_, "/", H5P_DEFAULT);
  ensure_parents(name);
  if (H5Lexists(file_, name.c_str(), H5P_DEFAULT) > 0) return H5Oopen(file_, name.c_str(), H5P_DEFAULT);
  hid_t g = H5Gcreate2(file_, name.c_str(), H5P_DEFAULT, group_plist(), H5P_DEFAULT);
  if (g < 0) fail("cannot create group " + name);
  return g;
}

void H5File::ensure_parents(const std::string& name) {
  std::size_t pos = name.find('/', 1);
  while (pos != std::string::npos) {
    const std::string parent = name.substr(0, pos);
    if (!parent.empty() && parent != "/" && H5Lexists(file_, parent.c_str(), H5P_DEFAULT) <= 0) {
      hid_t g = H5Gcreate2(file_, parent.c_str(), H5P_DEFAULT, group_plist(), H5P_DEFAULT);
      if (g < 0) fail("cannot create group " + parent);
      H5Gclose(g);
    }
    pos = name.find('/', pos + 1);
  }
}

template <class T, class A>
static void write_array(H5File& f, hid_t file, const std::string& name, const std::vector<T, A>& data,
                        std::vector<hsize_t> dims, hid_t type) {
  if (dims.empty()) dims = {static_cast<hsize_t>(data.size())};
  Handle space{H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose};
  if (H5Lexists(file, name.c_str(), H5P_DEFAULT) > 0) H5Ldelete(file, name.c_str(), H5P_DEFAULT);
  Handle ds{H5Dcreate2(file, name.c_str(), type, space.id, H5P_DEFAULT, dataset_plist(), H5P_DEFAULT), H5Dclose};
  if (ds.id < 0) throw std::runtime_error(f.path() + ": cannot create dataset " + name);
  if (!data.empty() && H5Dwrite(ds.id, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data()) < 0)
    throw std::runtime_error(f.path() + ": cannot write dataset " + name + " (disk full?)");
  const hid_t id = ds.id;
  ds.id = -1;
  if (H5Dclose(id) < 0) throw std::runtime_error(f.path() + ": cannot write dataset " + name + " (disk full?)");
}

template <class T, class A>
static void write_slab_of(H5File& f, hid_t file, const std::string& name, const std::vector<T, A>& data, hsize_t total,
                          hsize_t offset, hid_t type) {
  if (offset + data.size() > total)
    throw std::logic_error(f.path() + ": slab of " + name + " beyond the dataset's " + std::to_string(total) + " elements");
  Handle ds{-1, H5Dclose};
  if (H5Lexists(file, name.c_str(), H5P_DEFAULT) > 0) {
    ds.id = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
  } else {
    Handle space{H5Screate_simple(1, &total, nullptr), H5Sclose};
    // with a part to write, the storage is allocated by that write, as in write_array: the
    // file is byte for byte the one written whole by one process
    const hid_t plist = data.empty() && total > 0 ? early_dataset_plist() : dataset_plist();
    ds.id = H5Dcreate2(file, name.c_str(), type, space.id, H5P_DEFAULT, plist, H5P_DEFAULT);
  }
  if (ds.id < 0) throw std::runtime_error(f.path() + ": cannot create or open dataset " + name);
  if (!data.empty()) {
    const hsize_t count = data.size();
    Handle file_space{H5Dget_space(ds.id), H5Sclose};
    Handle memory{H5Screate_simple(1, &count, nullptr), H5Sclose};
    if (H5Sselect_hyperslab(file_space.id, H5S_SELECT_SET, &offset, nullptr, &count, nullptr) < 0 ||
        H5Dwrite(ds.id, type, memory.id, file_space.id, H5P_DEFAULT, data.data()) < 0)
      throw std::runtime_error(f.path() + ": cannot write elements " + std::to_string(offset) + "..." +
                               std::to_string(offset + count) + " of dataset " + name + " (disk full?)");
  }
  const hid_t id = ds.id;
  ds.id = -1;
  if (H5Dclose(id) < 0) throw std::runtime_error(f.path() + ": cannot write dataset " + name + " (disk full?)");
}

void H5File::write_slab(const std::string& name, const std::vector<double>& data, hsize_t total, hsize_t offset) {
  ensure_parents(name);
  write_slab_of(*this, file_, name, data, total, offset, H5T_NATIVE_DOUBLE);
}
void H5File::write_slab(const std::string& name, const std::vector<std::uint64_t>& data, hsize_t total, hsize_t offset) {
  ensure_parents(name);
  write_slab_of(*this, file_, name, data, total, offset, H5T_NATIVE_UINT64);
}

void H5File::write_slab(const std::string& name, const NoFillVector<double>& data, hsize_t total, hsize_t offset) {
  ensure_parents(name);
  write_slab_of(*this, file_, name, data, total, offset, H5T_NATIVE_DOUBLE);
}
void H5File::write_slab(const std::string& name, const NoFillVector<std::uint64_t>& data, hsize_t total, hsize_t offset) {
  ensure_parents(name);
  write_slab_of(*this, file_, name, data, total, offset, H5T_NATIVE_UINT64);
}

void H5File::write(const std::string& name, const std::vector<double>& data, std::vector<hsize_t> dims) {
  ensure_parents(name);
  write_array(*this, file_, name, data, std::move(dims), H5T_NATIVE_DOUBLE);
}
void H5File::write(const std::string& name, const std::vector<std::uint64_t>& data, std::vector<hsize_t> dims) {
  ensure_parents(name);
  write_array(*this, file_, name, data, std::move(dims), H5T_NATIVE_UINT64);
}
void H5File::write(const std::string& name, const NoFillVector<double>& data, std::vector<hsize_t> dims) {
  ensure_parents(name);
  write_array(*this, file_, name, data, std::move(dims), H5T_NATIVE_DOUBLE);
}
void H5File::write(const std::string& name, const NoFillVector<std::uint64_t>& data, std::vector<hsize_t> dims) {
  ensure_parents(name);
  write_array(*this, file_, name, data, std::move(dims), H5T_NATIVE_UINT64);
}
void H5File::write(const std::string& name, const std::vector<std::int64_t>& data, std::vector<hsize_t> dims) {
  ensure_parents(name);
  write_array(*this, file_, name, data, std::move(dims), H5T_NATIVE_INT64);
}

void H5File::write_scalar(const std::string& name, double value) {
  ensure_parents(name);
  write_array(*this, file_, name, std::vector<double>{value}, {1}, H5T_NATIVE_DOUBLE);
}
void H5File::write_scalar(const std::string& name, std::uint64_t value) {
  ensure_parents(name);
  write_array(*this, file_, name, std::vector<std::uint64_t>{value}, {1}, H5T_NATIVE_UINT64);
}

static hid_t string_type(std::size_t len) {
  hid_t t = H5Tcopy(H5T_C_S1);
  H5Tset_size(t, len == 0 ? 1 : len);
  H5Tset_strpad(t, H5T_STR_NULLPAD);
  return t;
}

void H5File::write_string(const std::string& name, const std::string& value) {
  ensure_parents(name);
  Handle type{string_type(value.size()), H5Tclose};
  Handle space{H5Screate(H5S_SCALAR), H5Sclose};
  if (H5Lexists(file_, name.c_str(), H5P_DEFAULT) > 0) H5Ldelete(file_, name.c_str(), H5P_DEFAULT);
  Handle ds{H5Dcreate2(file_, name.c_str(), type.id, space.id, H5P_DEFAULT, dataset_plist(), H5P_DEFAULT), H5Dclose};
  if (ds.id < 0) fail("cannot create dataset " + name);
  const std::string buf = value.empty() ? std::string(1, '\0') : value;
  if (H5Dwrite(ds.id, type.id, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0) fail("cannot write " + name);
}

void H5File::attribute(const std::string& object, const std::string& name, const std::string& value) {
  Handle obj{ensure_group(object), H5Oclose};
  Handle type{string_type(value.size()), H5Tclose};
  Handle space{H5Screate(H5S_SCALAR), H5Sclose};
  if (H5Aexists(obj.id, name.c_str()) > 0) H5Adelete(obj.id, name.c_str());
  Handle a{H5Acreate2(obj.id, name.c_str(), type.id, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose};
  if (a.id < 0) fail("cannot create attribute " + object + "@" + name);
  const std::string buf = value.empty() ? std::string(1, '\0') : value;
  if (H5Awrite(a.id, type.id, buf.data()) < 0) fail("cannot write attribute " + name);
}

void H5File::attribute(const std::string& object, const std::string& name, double value) {
  Handle obj{ensure_group(object), H5Oclose};
  Handle space{H5Screate(H5S_SCALAR), H5Sclose};
  if (H5Aexists(obj.id, name.c_str()) > 0) H5Adelete(obj.id, name.c_str());
  Handle a{H5Acreate2(obj.id, name.c_str(), H5T_NATIVE_DOUBLE, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose};
  if (a.id < 0 || H5Awrite(a.id, H5T_NATIVE_DOUBLE, &value) < 0) fail("cannot write attribute " + name);
}

void H5File::attribute(const std::string& object, const std::string& name, std::int64_t value) {
  Handle obj{ensure_group(object), H5Oclose};
  Handle space{H5Screate(H5S_SCALAR), H5Sclose};
  if (H5Aexists(obj.id, name.c_str()) > 0) H5Adelete(obj.id, name.c_str());
  Handle a{H5Acreate2(obj.id, name.c_str(), H5T_STD_I64LE, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose};
  if (a.id < 0 || H5Awrite(a.id, H5T_NATIVE_INT64, &value) < 0) fail("cannot write attribute " + name);
}

void H5File::attribute(const std::string& object, const std::string& name, const std::vector<std::int64_t>& values) {
  Handle obj{ensure_group(object), H5Oclose};
  const hsize_t n = values.size();
  Handle space{H5Screate_simple(1, &n, nullptr), H5Sclose};
  if (H5Aexists(obj.id, name.c_str()) > 0) H5Adelete(obj.id, name.c_str());
  Handle a{H5Acreate2(obj.id, name.c_str(), H5T_STD_I64LE, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose};
  if (a.id < 0 || H5Awrite(a.id, H5T_NATIVE_INT64, values.data()) < 0) fail("cannot write attribute " + name);
}

void H5File::attribute(const std::string& object, const std::string& name, const std::vector<std::string>& values) {
  Handle obj{ensure_group(object), H5Oclose};
  std::size_t width = 1;
  for (const auto& v : values) width = std::max(width, v.size());
  std::string buf(width * values.size(), '\0');  // fixed-length, null-padded
  for (std::size_t k = 0; k < values.size(); ++k) buf.replace(k * width, values[k].size(), values[k]);
  Handle type{string_type(width), H5Tclose};
  const hsize_t n = values.size();
  Handle space{H5Screate_simple(1, &n, nullptr), H5Sclose};
  if (H5Aexists(obj.id, name.c_str()) > 0) H5Adelete(obj.id, name.c_str());
  Handle a{H5Acreate2(obj.id, name.c_str(), type.id, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose};
  if (a.id < 0 || H5Awrite(a.id, type.id, buf.data()) < 0) fail("cannot write attribute " + name);
}

void H5File::soft_link(const std::string& name, const std::string& target) {
  if (!exists(target)) fail("cannot link " + name + " to " + target + ": no such object");
  ensure_parents(name);
  if (H5Lexists(file_, name.c_str(), H5P_DEFAULT) > 0) H5Ldelete(file_, name.c_str(), H5P_DEFAULT);
  if (H5Lcreate_soft(target.c_str(), file_, name.c_str(), H5P_DEFAULT, H5P_DEFAULT) < 0)
    fail("cannot create link " + name + " -> " + target);
}

std::string H5File::soft_link_target(const std::string& name) const {
  if (!exists(name)) return {};
  H5L_info_t info;  // unversioned names: HDF5 1.10 and 1.12+ alike
  if (H5Lget_info(file_, name.c_str(), &info, H5P_DEFAULT) < 0 || info.type != H5L_TYPE_SOFT) return {};
  std::string buf(info.u.val_size, '\0');  // val_size counts the terminating null
  if (H5Lget_val(file_, name.c_str(), buf.data(), buf.size(), H5P_DEFAULT) < 0) return {};
  buf.resize(buf.find('\0') == std::string::npos ? buf.size() : buf.find('\0'));
  return buf;
}

template <class T>
static std::vector<T> read_array(const H5File& f, hid_t file, const std::string& name, hid_t type,
                                 std::vector<hsize_t>* dims_out) {
  if (H5Lexists(file, name.c_str(), H5P_DEFAULT) <= 0) throw std::runtime_error(f.path() + ": missing dataset " + name);
  Handle ds{H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose};
  if (ds.id < 0) throw std::runtime_error(f.path() + ": cannot open dataset " + name);
  Handle space{H5Dget_space(ds.id), H5Sclose};
  const int rank = H5Sget_simple_extent_ndims(space.id);
  std::vector<hsize_t> dims(rank > 0 ? rank : 0);
  if (rank > 0) H5Sget_simple_extent_dims(space.id, dims.data(), nullptr);
  hsize_t count = 1;
  for (auto d : dims) count *= d;
  std::vector<T> out(count);
  if (count && H5Dread(ds.id, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0)
    throw std::runtime_error(f.path() + ": cannot read dataset " + name + " (wrong type or corrupt file)");
  if (dims_out) *dims_out = dims;
  return out;
}

template <class T>
static std::vector<T> read_slab_of(const H5File& f, hid_t file, const std::string& name, hsize_t offset, hsize_t count,
                                   hid_t type) {
  if (H5Lexists(file, name.c_str(), H5P_DEFAULT) <= 0) throw std::runtime_error(f.path() + ": missing dataset " + name);
  Handle ds{H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose};
  if (ds.id < 0) throw std::runtime_error(f.path() + ": cannot open dataset " + name);
  Handle space{H5Dget_space(ds.id), H5Sclose};
  hsize_t length = 0;
  if (H5Sget_simple_extent_ndims(space.id) != 1 || H5Sget_simple_extent_dims(space.id, &length, nullptr) < 0 ||
      offset + count > length)
    throw std::runtime_error(f.path() + ": dataset " + name + " is not a 1D array of at least " +
                             std::to_string(offset + count) + " elements");
  std::vector<T> out(count);
  if (count == 0) return out;
  Handle memory{H5Screate_simple(1, &count, nullptr), H5Sclose};
  if (H5Sselect_hyperslab(space.id, H5S_SELECT_SET, &offset, nullptr, &count, nullptr) < 0 ||
      H5Dread(ds.id, type, memory.id, space.id, H5P_DEFAULT, out.data()) < 0)
    throw std::runtime_error(f.path() + ": cannot read dataset " + name + " (wrong type or corrupt file)");
  return out;
}

std::vector<double> H5File::read_doubles_slab(const std::string& name, hsize_t offset, hsize_t count) const {
  return read_slab_of<double>(*this, file_, name, offset, count, H5T_NATIVE_DOUBLE);
}
std::vector<std::uint64_t> H5File::read_u64_slab(const std::string& name, hsize_t offset, hsize_t count) const {
  return read_slab_of<std::uint64_t>(*this, file_, name, offset, count, H5T_NATIVE_UINT64);
}
hsize_t H5File::length(const std::string& name) const {
  if (H5Lexists(file_, name.c_str(), H5P_DEFAULT) <= 0) fail("missing dataset " + name);
  Handle ds{H5Dopen2(file_, name.c_str(), H5P_DEFAULT), H5Dclose};
  Handle space{H5Dget_space(ds.id), H5Sclose};
  hsize_t n = 0;
  if (ds.id < 0 || H5Sget_simple_extent_ndims(space.id) != 1 || H5Sget_simple_extent_dims(space.id, &n, nullptr) < 0)
    fail("dataset " + name + " is not a 1D array");
  return n;
}

std::vector<double> H5File::read_doubles(const std::string& name, std::vector<hsize_t>* dims) const {
  return read_array<double>(*this, file_, name, H5T_NATIVE_DOUBLE, dims);
}
std::vector<std::uint64_t> H5File::read_u64(const std::string& name) const {
  return read_array<std::uint64_t>(*this, file_, name, H5T_NATIVE_UINT64, nullptr);
}
std::vector<std::int64_t> H5File::read_i64(const std::string& name) const {
  return read_array<std::int64_t>(*this, file_, name, H5T_NATIVE_INT64, nullptr);
}
double H5File::read_scalar(const std::string& name) const {
  auto v = read_doubles(name);
  if (v.size() != 1) fail(name + ": expected a scalar");
  return v[0];
}
std::uint64_t H5File::read_scalar_u64(const std::string& name) const {
  auto v = read_u64(name);
  if (v.size() != 1) fail(name + ": expected a scalar");
  return v[0];
}

std::string H5File::read_string(const std::string& name) const {
  if (H5Lexists(file_, name.c_str(), H5P_DEFAULT) <= 0) fail("missing dataset " + name);
  Handle ds{H5Dopen2(file_, name.c_str(), H5P_DEFAULT), H5Dclose};
  Handle type{H5Dget_type(ds.id), H5Tclose};
  const std::size_t size = H5Tget_size(type.id);
  std::string buf(size, '\0');
  if (H5Dread(ds.id, type.id, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0) fail("cannot read " + name);
  buf.resize(buf.find('\0') == std::string::npos ? buf.size() : buf.find('\0'));
  return buf;
}

std::string H5File::read_attribute(const std::string& object, const std::string& name) const {
  Handle obj{H5Oopen(file_, object.c_str(), H5P_DEFAULT), H5Oclose};
  if (obj.id < 0 || H5Aexists(obj.id, name.c_str()) <= 0) fail("missing attribute " + object + "@" + name);
  Handle a{H5Aopen(obj.id, name.c_str(), H5P_DEFAULT), H5Aclose};
  Handle type{H5Aget_type(a.id), H5Tclose};
  const std::size_t size = H5Tget_size(type.id);
  std::string buf(size, '\0');
  if (H5Aread(a.id, type.id, buf.data()) < 0) fail("cannot read attribute " + name);
  buf.resize(buf.find('\0') == std::string::npos ? buf.size() : buf.find('\0'));
  return buf;
}

std::int64_t H5File::read_int_attribute(const std::string& object, const std::string& name) const {
  Handle obj{H5Oopen(file_, object.c_str(), H5P_DEFAULT), H5Oclose};
  if (obj.id < 0 || H5Aexists(obj.id, name.c_str()) <= 0) fail("missing attribute " + object + "@" + name);
  Handle a{H5Aopen(obj.id, name.c_str(), H5P_DEFAULT), H5Aclose};
  Handle type{H5Aget_type(a.id), H5Tclose};
  Handle space{H5Aget_space(a.id), H5Sclose};
  if (H5Tget_class(type.id) != H5T_INTEGER || H5Sget_simple_extent_npoints(space.id) != 1)
    fail("attribute " + object + "@" + name + " is not a scalar integer");
  std::int64_t value = 0;
  if (H5Aread(a.id, H5T_NATIVE_INT64, &value) < 0) fail("cannot read attribute " + name);
  return value;
}

std::vector<std::string> H5File::attribute_names(const std::string& object) const {
  Handle obj{H5Oopen(file_, object.c_str(), H5P_DEFAULT), H5Oclose};
  if (obj.id < 0) fail("missing object " + object);
  std::vector<std::string> names;
  const herr_t status = H5Aiterate2(
      obj.id, H5_INDEX_NAME, H5_ITER_INC, nullptr,
      [](hid_t, const char* name, const H5A_info_t*, void* out) -> herr_t {
        static_cast<std::vector<std::string>*>(out)->emplace_back(name);
        return 0;
      },
      &names);
  if (status < 0) fail("cannot list the attributes of " + object);
  return names;
}

}  // namespace grainbath

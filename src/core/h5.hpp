#pragma once
// Minimal HDF5 (C API) writer/reader used for results.h5, checkpoints and background grids.
// Errors throw std::runtime_error naming the file and the object; HDF5's own error stack
// printing is switched off so a user sees one clear line.
#include <hdf5.h>

#include <cstdint>
#include <string>
#include <vector>

#include "core/no_fill_vector.hpp"

namespace grainbath {

class H5File {
 public:
  // update: an existing file opened for writing (the ranks adding their particle slabs to
  // a checkpoint that rank 0 created, src/dsmc/checkpoint.cpp)
  enum class Mode { create, read, update };
  H5File(const std::string& path, Mode mode);
  ~H5File();
  H5File(const H5File&) = delete;
  H5File& operator=(const H5File&) = delete;

  // Datasets; intermediate groups are created. dims empty: 1D of data.size().
  void write(const std::string& name, const std::vector<double>& data, std::vector<hsize_t> dims = {});
  void write(const std::string& name, const std::vector<std::uint64_t>& data, std::vector<hsize_t> dims = {});
  void write(const std::string& name, const std::vector<std::int64_t>& data, std::vector<hsize_t> dims = {});
  // the DSMC particle arrays (core/no_fill_vector.hpp): the same datasets
  void write(const std::string& name, const NoFillVector<double>& data, std::vector<hsize_t> dims = {});
  void write(const std::string& name, const NoFillVector<std::uint64_t>& data, std::vector<hsize_t> dims = {});
  // One rank's part [offset, offset + data.size()) of a 1D dataset of `total` elements: the
  // dataset is created if missing, its storage where write() would put it (the file does
  // not depend on how the array was split); an empty part writes nothing.
  void write_slab(const std::string& name, const std::vector<double>& data, hsize_t total, hsize_t offset);
  void write_slab(const std::string& name, const std::vector<std::uint64_t>& data, hsize_t total, hsize_t offset);
  void write_slab(const std::string& name, const NoFillVector<double>& data, hsize_t total, hsize_t offset);
  void write_slab(const std::string& name, const NoFillVector<std::uint64_t>& data, hsize_t total, hsize_t offset);
  void write_string(const std::string& name, const std::string& value);
  void write_scalar(const std::string& name, double value);
  void write_scalar(const std::string& name, std::uint64_t value);

  // Attributes on an existing object ("/" for the file root); the object is created as a
  // group if missing.
  void attribute(const std::string& object, const std::string& name, const std::string& value);
  void attribute(const std::string& object, const std::string& name, double value);
  // integer attributes: a scalar, or an array (H5MD's version = [1, 1])
  void attribute(const std::string& object, const std::string& name, std::int64_t value);
  void attribute(const std::string& object, const std::string& name, const std::vector<std::int64_t>& values);
  // an array of fixed-length strings (H5MD's box boundary, one per dimension)
  void attribute(const std::string& object, const std::string& name, const std::vector<std::string>& values);

  // A soft link `name` -> `target` (absolute path of an existing object; intermediate groups
  // of `name` are created, an earlier link or object at `name` is replaced). For names kept
  // after a layout change: a reader of the old path gets the new object, no data is copied.
  // The target must exist when the link is made, so a typo fails here, not in a user's script.
  void soft_link(const std::string& name, const std::string& target);
  // The target of the soft link `name`; empty when `name` is missing or not a soft link.
  std::string soft_link_target(const std::string& name) const;

  bool exists(const std::string& name) const;
  std::vector<double> read_doubles(const std::string& name, std::vector<hsize_t>* dims = nullptr) const;
  std::vector<std::uint64_t> read_u64(const std::string& name) const;
  std::vector<std::int64_t> read_i64(const std::string& name) const;
  // Elements [offset, offset + count) of a 1D dataset, and its length (reading a checkpoint
  // in chunks: src/core/checkpoint.cpp).
  std::vector<double> read_doubles_slab(const std::string& name, hsize_t offset, hsize_t count) const;
  std::vector<std::uint64_t> read_u64_slab(const std::string& name, hsize_t offset, hsize_t count) const;
  hsize_t length(const std::string& name) const;
  std::string read_string(const std::string& name) const;
  double read_scalar(const std::string& name) const;
  std::uint64_t read_scalar_u64(const std::string& name) const;
  std::string read_attribute(const std::string& object, const std::string& name) const;
  // a scalar integer attribute (converted by HDF5 from any integer type)
  std::int64_t read_int_attribute(const std::string& object, const std::string& name) const;
  // Names of the attributes of `object`, in creation-index or name order.
  std::vector<std::string> attribute_names(const std::string& object) const;

  // Flushes and closes the file, throwing if any write failed (disk full, quota, file-size
  // limit): HDF5 reports such failures only when data are flushed or objects closed.
  void close();
  const std::string& path() const { return path_; }

 private:
  hid_t ensure_group(const std::string& name);
  void ensure_parents(const std::string& name);
  [[noreturn]] void fail(const std::string& what) const;
  hid_t file_ = -1;
  std::string path_;
};

}  // namespace grainbath

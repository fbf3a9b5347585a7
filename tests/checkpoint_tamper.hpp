#pragma once
// Test support: a checkpoint rewritten with one array changed and its checksum made to match,
// so that only the solver's load checks can tell it from a good one. Such a file is what an
// earlier build, another build or a faulty writer leaves: it verifies, and its layout is
// wrong. (A damaged file is caught by the checksum; tests of that truncate or flip bits.)
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include <hdf5.h>

#include "core/checkpoint.hpp"
#include "core/h5.hpp"

namespace grainbath::testing {

// The checksum the loader computes (core/checkpoint.hpp, Fnv1a): the arrays of `names` (the
// solver's list order) that the file holds, each after its length.
inline void reseal_checkpoint(const std::filesystem::path& file, const std::vector<std::string>& names) {
  std::vector<std::pair<std::string, bool>> arrays;  // name, integer
  {
    const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) throw std::runtime_error(file.string() + ": cannot open");
    for (const std::string& name : names) {
      if (H5Lexists(f, ("/" + name).c_str(), H5P_DEFAULT) <= 0) continue;  // optional, absent
      const hid_t d = H5Dopen2(f, ("/" + name).c_str(), H5P_DEFAULT);
      const hid_t type = H5Dget_type(d);
      arrays.emplace_back(name, H5Tget_class(type) == H5T_INTEGER);
      H5Tclose(type);
      H5Dclose(d);
    }
    H5Fclose(f);
  }
  Fnv1a sum;
  H5File h(file.string(), H5File::Mode::update);
  for (const auto& [name, integer] : arrays) {
    if (integer) {
      const auto v = h.read_u64("/" + name);
      sum.add_length(v.size()), sum.add_elements(v);
    } else {
      const auto v = h.read_doubles("/" + name);
      sum.add_length(v.size()), sum.add_elements(v);
    }
  }
  char hex[24];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(sum.h));
  h.attribute("/", "checksum", std::string(hex));
  h.close();
}

// Replaces array `name` of `file` by `values` and reseals the file.
template <class T>
void rewrite_checkpoint_array(const std::filesystem::path& file, const std::vector<std::string>& names,
                              const std::string& name, const std::vector<T>& values) {
  {
    const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    if (f < 0) throw std::runtime_error(file.string() + ": cannot open");
    const herr_t e = H5Ldelete(f, ("/" + name).c_str(), H5P_DEFAULT);
    H5Fclose(f);
    if (e < 0) throw std::runtime_error(file.string() + ": no array " + name);
  }
  {
    H5File h(file.string(), H5File::Mode::update);
    h.write("/" + name, values);
    h.close();
  }
  reseal_checkpoint(file, names);
}

inline std::vector<double> checkpoint_doubles(const std::filesystem::path& file, const std::string& name) {
  return H5File(file.string(), H5File::Mode::read).read_doubles("/" + name);
}
inline std::vector<std::uint64_t> checkpoint_integers(const std::filesystem::path& file, const std::string& name) {
  return H5File(file.string(), H5File::Mode::read).read_u64("/" + name);
}

}  // namespace grainbath::testing

#include "core/dataset.h"

#include <fcntl.h>
#include <hdf5.h>
#include <unistd.h>

#include <filesystem>
#include <cstring>
#include <functional>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/config.h"
#include "core/isolate.h"

namespace dd {
namespace {

namespace fs = std::filesystem;

// HDF5 1.10.8 closes every file still open when the process exits, and crashes (SIGSEGV in
// H5F__close_cb) on a file whose close failed, as a close does when the disk is full: `collect` wrote
// its clear error and then died of the signal. Every file here is closed by its H5 owner, and one
// whose close failed is a temporary already removed, so the library's exit handler has nothing to
// save: it is not installed. This must precede every other HDF5 call, so it runs at load time (this
// file is the only one that calls HDF5).
[[maybe_unused]] const herr_t kNoHdf5ExitHandler = H5dont_atexit();

// Owns an HDF5 id and closes it with the matching function.
class H5 {
 public:
  H5(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~H5() {
    if (id_ >= 0) close_(id_);
  }
  H5(H5&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  H5(const H5&) = delete;
  H5& operator=(const H5&) = delete;
  operator hid_t() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

struct SilenceHdf5 {
  SilenceHdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }
};
const SilenceHdf5 kSilence;  // errors become Error exceptions with the file and field named

void check(herr_t status, const std::string& path, const std::string& what) {
  if (status < 0) throw Error(path + ": " + what + " failed");
}

void write_attr_int(hid_t obj, const char* name, int64_t value, const std::string& path) {
  if (H5Aexists(obj, name) > 0) check(H5Adelete(obj, name), path, std::string("replacing attribute ") + name);
  H5 space(H5Screate(H5S_SCALAR), H5Sclose);
  H5 attr(H5Acreate2(obj, name, H5T_NATIVE_INT64, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attr.ok()) throw Error(path + ": could not create attribute " + name);
  check(H5Awrite(attr, H5T_NATIVE_INT64, &value), path, std::string("writing attribute ") + name);
}

void write_attr_string(hid_t obj, const char* name, const std::string& value, const std::string& path) {
  if (H5Aexists(obj, name) > 0) check(H5Adelete(obj, name), path, std::string("replacing attribute ") + name);
  H5 type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type, std::max<size_t>(1, value.size()));
  H5Tset_strpad(type, H5T_STR_NULLPAD);
  H5 space(H5Screate(H5S_SCALAR), H5Sclose);
  H5 attr(H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attr.ok()) throw Error(path + ": could not create attribute " + name);
  check(H5Awrite(attr, type, value.empty() ? "" : value.data()), path, std::string("writing attribute ") + name);
}

int64_t read_attr_int(hid_t obj, const char* name, const std::string& where) {
  if (H5Aexists(obj, name) <= 0) throw Error(where + ": missing attribute '" + name + "'");
  H5 attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  int64_t v = 0;
  if (H5Aread(attr, H5T_NATIVE_INT64, &v) < 0) throw Error(where + ": attribute '" + name + "' is not an integer");
  return v;
}

std::string read_attr_string(hid_t obj, const char* name, const std::string& where) {
  if (H5Aexists(obj, name) <= 0) throw Error(where + ": missing attribute '" + name + "'");
  H5 attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  H5 type(H5Aget_type(attr), H5Tclose);
  if (H5Tget_class(type) != H5T_STRING) throw Error(where + ": attribute '" + name + "' is not a string");
  if (H5Tis_variable_str(type) > 0) {
    char* s = nullptr;
    H5 mem(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mem, H5T_VARIABLE);
    if (H5Aread(attr, mem, &s) < 0) throw Error(where + ": attribute '" + name + "' unreadable");
    std::string out = s ? s : "";
    H5free_memory(s);
    return out;
  }
  const size_t n = H5Tget_size(type);
  std::string out(n, '\0');
  if (H5Aread(attr, type, out.data()) < 0) throw Error(where + ": attribute '" + name + "' unreadable");
  out.resize(std::strlen(out.c_str()));
  return out;
}

void write_matrix(hid_t parent, const char* name, const Mat& m, const std::string& path) {
  const hsize_t dims[2] = {static_cast<hsize_t>(m.rows()), static_cast<hsize_t>(m.cols())};
  H5 space(H5Screate_simple(2, dims, nullptr), H5Sclose);
  H5 ds(H5Dcreate2(parent, name, H5T_IEEE_F32LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
  if (!ds.ok()) throw Error(path + ": could not create dataset " + name);
  check(H5Dwrite(ds, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, m.data()), path, std::string("writing ") + name);
}

template <typename T>
void write_vector(hid_t parent, const char* name, const std::vector<T>& v, hid_t file_type, hid_t mem_type,
                  const std::string& path) {
  const hsize_t dims[1] = {static_cast<hsize_t>(v.size())};
  H5 space(H5Screate_simple(1, dims, nullptr), H5Sclose);
  H5 ds(H5Dcreate2(parent, name, file_type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
  if (!ds.ok()) throw Error(path + ": could not create dataset " + name);
  check(H5Dwrite(ds, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), path, std::string("writing ") + name);
}

Mat read_matrix(hid_t parent, const char* name, const std::string& where) {
  if (H5Lexists(parent, name, H5P_DEFAULT) <= 0) throw Error(where + ": missing dataset '" + name + "'");
  H5 ds(H5Dopen2(parent, name, H5P_DEFAULT), H5Dclose);
  H5 space(H5Dget_space(ds), H5Sclose);
  hsize_t dims[2] = {0, 1};
  const int rank = H5Sget_simple_extent_ndims(space);
  if (rank < 1 || rank > 2) throw Error(where + ": dataset '" + name + "' must be 1-D or 2-D");
  H5Sget_simple_extent_dims(space, dims, nullptr);
  // a corrupt header can claim any size: refuse more than 2^31 values (8 GB) before allocating
  const hsize_t cols = rank == 2 ? dims[1] : 1;
  if (cols != 0 && dims[0] > (hsize_t{1} << 31) / cols)
    throw Error(where + ": dataset '" + name + "' claims " + std::to_string(dims[0]) + " x " + std::to_string(cols) +
                " values (corrupt)");
  Mat m(static_cast<Eigen::Index>(dims[0]), static_cast<Eigen::Index>(cols));
  if (H5Dread(ds, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, m.data()) < 0)
    throw Error(where + ": dataset '" + name + "' unreadable");
  return m;
}

template <typename T>
std::vector<T> read_vector(hid_t parent, const char* name, hid_t mem_type, size_t expected, const std::string& where,
                           bool required) {
  if (H5Lexists(parent, name, H5P_DEFAULT) <= 0) {
    if (required) throw Error(where + ": missing dataset '" + name + "'");
    return {};
  }
  H5 ds(H5Dopen2(parent, name, H5P_DEFAULT), H5Dclose);
  H5 space(H5Dget_space(ds), H5Sclose);
  const hssize_t n = H5Sget_simple_extent_npoints(space);
  if (n != static_cast<hssize_t>(expected))
    throw Error(where + ": dataset '" + name + "' has " + std::to_string(n) + " values, expected " + std::to_string(expected));
  std::vector<T> v(expected);
  if (H5Dread(ds, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0) throw Error(where + ": dataset '" + name + "' unreadable");
  return v;
}

void fsync_path(const std::string& p) {
  const int fd = ::open(p.c_str(), O_RDONLY);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}

H5 open_readonly(const std::string& path) {
  if (!fs::exists(path)) throw Error(path + ": no such data set file");
  H5 file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) throw Error(path + ": not a readable HDF5 file (corrupt or truncated)");
  return file;
}

// Walks /data/demo_<i> in index order; robomimic numbers demos from 0 without gaps.
void for_each_demo(hid_t data, const std::string& path, int count, const std::function<void(hid_t, const std::string&)>& fn) {
  for (int i = 0; i < count; ++i) {
    const std::string name = "demo_" + std::to_string(i);
    if (H5Lexists(data, name.c_str(), H5P_DEFAULT) <= 0) throw Error(path + ": missing group /data/" + name);
    H5 demo(H5Gopen2(data, name.c_str(), H5P_DEFAULT), H5Gclose);
    fn(demo, path + " /data/" + name);
  }
}

int count_demos(hid_t data) {
  H5G_info_t info;
  if (H5Gget_info(data, &info) < 0) return 0;
  return static_cast<int>(info.nlinks);
}

}  // namespace

Episode RecordedEpisode::expert_steps() const {
  std::vector<Eigen::Index> rows;
  for (Eigen::Index i = 0; i < obs.rows(); ++i)
    if (intervention.empty() || intervention[static_cast<size_t>(i)]) rows.push_back(i);
  Episode e{Mat(static_cast<Eigen::Index>(rows.size()), obs.cols()), Mat(static_cast<Eigen::Index>(rows.size()), actions.cols())};
  for (size_t k = 0; k < rows.size(); ++k) {
    e.obs.row(static_cast<Eigen::Index>(k)) = obs.row(rows[k]);
    e.actions.row(static_cast<Eigen::Index>(k)) = actions.row(rows[k]);
  }
  return e;
}

Episode RecordedEpisode::all_steps() const { return Episode{obs, actions}; }

DatasetWriter::DatasetWriter(std::string path, std::string env_args) : path_(std::move(path)), env_args_(std::move(env_args)) {
  if (fs::exists(path_)) {
    const DatasetInfo info = dataset_info(path_);
    if (info.env_args != env_args_)
      throw Error(path_ + ": attribute env_args differs from this run's (" + info.env_args + " vs " + env_args_ +
                  "); write to another file");
    episodes_ = info.episodes;
    total_ = info.total;
  }
}

namespace {

void check_episode(const RecordedEpisode& ep, const std::string& path) {
  const auto T = static_cast<size_t>(ep.steps());
  if (T == 0) throw Error(path + ": refusing to write an empty episode");
  if (static_cast<size_t>(ep.actions.rows()) != T) throw Error(path + ": episode obs and actions differ in length");
  if ((!ep.rewards.empty() && ep.rewards.size() != T) || (!ep.dones.empty() && ep.dones.size() != T) ||
      (!ep.intervention.empty() && ep.intervention.size() != T) || (!ep.actor.empty() && ep.actor.size() != T))
    throw Error(path + ": episode rewards/dones/intervention/actor differ in length from obs");
  for (uint8_t a : ep.actor)
    if (a >= std::size(kActorLabels)) throw Error(path + ": episode has an actor code " + std::to_string(a) + " outside kActorLabels");
  if (!ep.obs.allFinite() || !ep.actions.allFinite())
    throw Error(path + ": episode contains NaN or infinite observations or actions; not written");
}

// /data/demo_<index> with everything robomimic's SequenceDataset reads by default.
void write_demo(hid_t data, int index, const RecordedEpisode& ep, const std::string& path) {
  const auto T = static_cast<size_t>(ep.steps());
  const std::string name = "demo_" + std::to_string(index);
  H5 demo(H5Gcreate2(data, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  if (!demo.ok()) throw Error(path + ": could not create group /data/" + name);
  {
    H5 obs(H5Gcreate2(demo, "obs", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    write_matrix(obs, "state", ep.obs, path);
  }
  {
    // The observation after each step: the next row; after the last step, the last row again (the
    // state the final action led to is not recorded).
    Mat next(ep.obs.rows(), ep.obs.cols());
    next.topRows(ep.obs.rows() - 1) = ep.obs.bottomRows(ep.obs.rows() - 1);
    next.row(ep.obs.rows() - 1) = ep.obs.row(ep.obs.rows() - 1);
    H5 next_obs(H5Gcreate2(demo, "next_obs", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    write_matrix(next_obs, "state", next, path);
  }
  write_matrix(demo, "actions", ep.actions, path);
  const std::vector<float> rewards = ep.rewards.empty() ? std::vector<float>(T, 0.f) : ep.rewards;
  std::vector<uint8_t> dones = ep.dones;
  if (dones.empty()) {
    dones.assign(T, 0);
    dones.back() = 1;
  }
  const std::vector<uint8_t> flags = ep.intervention.empty() ? std::vector<uint8_t>(T, 0) : ep.intervention;
  write_vector(demo, "rewards", rewards, H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, path);
  write_vector(demo, "dones", dones, H5T_STD_U8LE, H5T_NATIVE_UINT8, path);
  write_vector(demo, "intervention", flags, H5T_STD_U8LE, H5T_NATIVE_UINT8, path);
  if (!ep.actor.empty()) {
    write_vector(demo, "actor", ep.actor, H5T_STD_U8LE, H5T_NATIVE_UINT8, path);
    static const std::string labels = fmt::format("{}", fmt::join(kActorLabels, ","));
    H5 actor(H5Dopen2(demo, "actor", H5P_DEFAULT), H5Dclose);
    write_attr_string(actor, "labels", labels, path);
  }
  write_attr_int(demo, "num_samples", static_cast<int64_t>(T), path);
  write_attr_int(demo, "success", ep.success ? 1 : 0, path);
  write_attr_string(demo, "source", ep.source, path);
}

// A robomimic filter key: /mask/<key>, the demo names as fixed-width, null-padded byte strings (numpy
// reads them back without the padding). The dataset is chunked and resizable, so appending a demo
// extends it in place instead of deleting and re-creating it (HDF5 does not reclaim deleted space).
constexpr size_t kMaskNameWidth = 32;  // "demo_" and up to 26 digits

// Whether /mask/<key> is in the layout write_filter_key extends: chunked, of kMaskNameWidth-byte strings.
bool extendable_filter_key(hid_t mask, const char* key) {
  H5 ds(H5Dopen2(mask, key, H5P_DEFAULT), H5Dclose);
  if (!ds.ok()) return false;
  H5 props(H5Dget_create_plist(ds), H5Pclose);
  H5 type(H5Dget_type(ds), H5Tclose);
  return props.ok() && type.ok() && H5Pget_layout(props) == H5D_CHUNKED && H5Tget_class(type) == H5T_STRING &&
         H5Tis_variable_str(type) == 0 && H5Tget_size(type) == kMaskNameWidth;
}

void write_filter_key(hid_t file, const char* key, const std::vector<std::string>& demos, const std::string& path) {
  if (H5Lexists(file, "mask", H5P_DEFAULT) <= 0) {
    H5 group(H5Gcreate2(file, "mask", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    if (!group.ok()) throw Error(path + ": could not create group /mask");
  }
  H5 mask(H5Gopen2(file, "mask", H5P_DEFAULT), H5Gclose);
  std::string packed(kMaskNameWidth * demos.size(), '\0');
  for (size_t i = 0; i < demos.size(); ++i) {
    if (demos[i].size() > kMaskNameWidth) throw Error(path + ": demo name '" + demos[i] + "' is too long for /mask/" + key);
    std::memcpy(&packed[i * kMaskNameWidth], demos[i].data(), demos[i].size());
  }
  H5 type(H5Tcopy(H5T_C_S1), H5Tclose);
  check(H5Tset_size(type, kMaskNameWidth), path, "a string type");
  check(H5Tset_strpad(type, H5T_STR_NULLPAD), path, "a string type");
  const hsize_t dims[1] = {demos.size()};
  const std::string where = std::string("/mask/") + key;
  bool exists = H5Lexists(mask, key, H5P_DEFAULT) > 0;
  if (exists && !extendable_filter_key(mask, key)) {
    // Written before filter keys were resizable (contiguous, sized to the longest name): re-created
    // once in the current layout, so data sets from earlier versions still take appends.
    check(H5Ldelete(mask, key, H5P_DEFAULT), path, "replacing " + where);
    exists = false;
  }
  H5 ds = [&] {
    if (exists) return H5(H5Dopen2(mask, key, H5P_DEFAULT), H5Dclose);
    const hsize_t max_dims[1] = {H5S_UNLIMITED};
    const hsize_t chunk[1] = {64};
    H5 space(H5Screate_simple(1, dims, max_dims), H5Sclose);
    H5 props(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
    check(H5Pset_chunk(props, 1, chunk), path, "chunking " + where);
    return H5(H5Dcreate2(mask, key, type, space, H5P_DEFAULT, props, H5P_DEFAULT), H5Dclose);
  }();
  if (!ds.ok()) throw Error(path + ": could not " + (exists ? "open" : "create") + " dataset " + where);
  if (exists) check(H5Dset_extent(ds, dims), path, "extending " + where);
  if (!demos.empty()) check(H5Dwrite(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, packed.data()), path, "writing " + where);
}

// The train/valid split of `episodes` demos: every tenth demo (demo_9, demo_19, ...) is for
// validation, so a demo never changes sides as the file grows.
void write_split(hid_t file, int episodes, const std::string& path) {
  std::vector<std::string> train, valid;
  for (int i = 0; i < episodes; ++i) (i % 10 == 9 ? valid : train).push_back("demo_" + std::to_string(i));
  write_filter_key(file, "train", train, path);
  write_filter_key(file, "valid", valid, path);
}

H5 create_file(const std::string& tmp, const std::string& env_args, const std::string& path) {
  H5 file(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) throw Error(path + ": could not create the data set file");
  H5 data(H5Gcreate2(file, "data", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  write_attr_int(data, "total", 0, path);
  write_attr_string(data, "env_args", env_args, path);
  return file;
}

// " (the disk holding it is full: N bytes free)" when the file's disk has less room than another copy
// of it needs, else "": a write that fails for want of space names the cause.
std::string disk_full_hint(const std::string& path) {
  std::error_code ec;
  const fs::path dir = fs::absolute(path, ec).parent_path();
  const fs::space_info space = fs::space(dir, ec);
  if (ec) return "";
  const uintmax_t size = fs::exists(path, ec) ? fs::file_size(path, ec) : 0;
  if (space.available >= size + (1u << 20)) return "";
  return " (the disk holding it is full: " + std::to_string(space.available) + " bytes free, the file is " + std::to_string(size) +
         " bytes and appending writes a copy of it; the file still holds every earlier episode)";
}

// Moves a finished temporary file over `path`, durably.
void commit_file(const std::string& tmp, const std::string& path) {
  fsync_path(tmp);
  fs::rename(tmp, path);
  fsync_path(fs::absolute(path).parent_path().string());
}

// Writes `path` by way of path.partial: fill(tmp) writes (and closes) the temporary file, which then
// replaces `path` durably. On any failure the temporary file is removed, `path` is left as it was, and
// the error names the file, `what` was being written and, when the disk is full, says so.
void write_via_temporary(const std::string& path, const char* what, const std::function<void(const std::string&)>& fill) {
  const std::string tmp = path + ".partial";
  std::error_code ec;
  fs::remove(tmp, ec);
  try {
    fill(tmp);
    commit_file(tmp, path);
  } catch (const fs::filesystem_error& e) {
    fs::remove(tmp, ec);
    throw Error(path + ": could not write " + what + ": " + e.code().message() + disk_full_hint(path));
  } catch (const Error& e) {
    fs::remove(tmp, ec);
    throw Error(std::string(e.what()) + disk_full_hint(path));
  } catch (...) {
    fs::remove(tmp, ec);
    throw;
  }
}

}  // namespace

void DatasetWriter::append(const RecordedEpisode& ep) {
  check_episode(ep, path_);
  const auto T = static_cast<int64_t>(ep.steps());
  write_via_temporary(path_, "the episode", [&](const std::string& tmp) {
    if (fs::exists(path_)) fs::copy_file(path_, tmp, fs::copy_options::overwrite_existing);
    else create_file(tmp, env_args_, path_);
    H5 file(H5Fopen(tmp.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose);
    if (!file.ok()) throw Error(path_ + ": could not open a copy for appending");
    H5 data(H5Gopen2(file, "data", H5P_DEFAULT), H5Gclose);
    write_demo(data, episodes_, ep, path_);
    write_attr_int(data, "total", total_ + T, path_);
    write_split(file, episodes_ + 1, path_);
    check(H5Fflush(file, H5F_SCOPE_GLOBAL), path_, "flush");
  });
  ++episodes_;
  total_ += T;
}

void write_dataset(const std::string& path, const std::string& env_args, const std::vector<RecordedEpisode>& episodes) {
  for (const RecordedEpisode& ep : episodes) check_episode(ep, path);
  write_via_temporary(path, "the data set", [&](const std::string& tmp) {
    H5 file = create_file(tmp, env_args, path);
    H5 data(H5Gopen2(file, "data", H5P_DEFAULT), H5Gclose);
    int64_t total = 0;
    for (size_t i = 0; i < episodes.size(); ++i) {
      write_demo(data, static_cast<int>(i), episodes[i], path);
      total += episodes[i].steps();
    }
    write_attr_int(data, "total", total, path);
    write_split(file, static_cast<int>(episodes.size()), path);
    check(H5Fflush(file, H5F_SCOPE_GLOBAL), path, "flush");
  });
}

DatasetInfo dataset_info(const std::string& path) {
  DatasetInfo info;
  read_dataset(path, &info);
  return info;
}

namespace {

std::vector<RecordedEpisode> read_dataset_here(const std::string& path, DatasetInfo* info);

}  // namespace

// libhdf5 1.10 is not memory-safe on corrupt files (tests/fuzz found a heap overflow in
// H5O__attr_exists): the file is parsed in a child process, which sends the episodes back.
std::vector<RecordedEpisode> read_dataset(const std::string& path, DatasetInfo* info) {
  if (!fs::exists(path)) throw Error(path + ": no such data set file");
  Bytes in(read_in_child(path, "libhdf5", [&] {
    DatasetInfo i;
    std::vector<RecordedEpisode> eps;
    try {
      eps = read_dataset_here(path, &i);
    } catch (const std::bad_alloc&) {
      throw Error(path + ": reading it needs more memory than there is (a corrupt size?)");
    }
    Bytes b;
    b.put<int64_t>(i.total);
    b.put<int64_t>(i.intervention_steps);
    b.put<int32_t>(i.successes);
    b.put<int32_t>(i.obs_dim);
    b.put<int32_t>(i.action_dim);
    b.put_string(i.env_args);
    b.put<uint64_t>(eps.size());
    for (const RecordedEpisode& e : eps) {
      b.put_mat(e.obs);
      b.put_mat(e.actions);
      b.put_all(e.rewards.data(), e.rewards.size());
      b.put_all(e.dones.data(), e.dones.size());
      b.put_all(e.intervention.data(), e.intervention.size());
      b.put_all(e.actor.data(), e.actor.size());
      b.put<uint8_t>(e.success);
      b.put_string(e.source);
    }
    return std::move(b.out);
  }), "read_dataset: the reading child process");
  DatasetInfo i;
  i.path = path;
  i.total = in.get<int64_t>();
  i.intervention_steps = in.get<int64_t>();
  i.successes = in.get<int32_t>();
  i.obs_dim = in.get<int32_t>();
  i.action_dim = in.get<int32_t>();
  i.env_args = in.get_string();
  std::vector<RecordedEpisode> eps(in.get<uint64_t>());
  for (RecordedEpisode& e : eps) {
    e.obs = in.get_mat();
    e.actions = in.get_mat();
    e.rewards = in.get_all<float>();
    e.dones = in.get_all<uint8_t>();
    e.intervention = in.get_all<uint8_t>();
    e.actor = in.get_all<uint8_t>();
    e.success = in.get<uint8_t>() != 0;
    e.source = in.get_string();
  }
  i.episodes = static_cast<int>(eps.size());
  if (info) *info = i;
  return eps;
}

namespace {

std::vector<RecordedEpisode> read_dataset_here(const std::string& path, DatasetInfo* info) {
  H5 file = open_readonly(path);
  if (H5Lexists(file, "data", H5P_DEFAULT) <= 0) throw Error(path + ": missing group /data (not a robomimic-layout data set)");
  H5 data(H5Gopen2(file, "data", H5P_DEFAULT), H5Gclose);
  DatasetInfo in;
  in.path = path;
  in.env_args = read_attr_string(data, "env_args", path + " /data");
  const int64_t total = read_attr_int(data, "total", path + " /data");
  std::vector<RecordedEpisode> out;
  for_each_demo(data, path, count_demos(data), [&](hid_t demo, const std::string& where) {
    RecordedEpisode ep;
    if (H5Lexists(demo, "obs", H5P_DEFAULT) <= 0) throw Error(where + ": missing group 'obs'");
    H5 obs(H5Gopen2(demo, "obs", H5P_DEFAULT), H5Gclose);
    ep.obs = read_matrix(obs, "state", where + "/obs");
    ep.actions = read_matrix(demo, "actions", where);
    const auto T = static_cast<size_t>(ep.obs.rows());
    if (static_cast<size_t>(ep.actions.rows()) != T) throw Error(where + ": 'actions' and 'obs/state' differ in length");
    if (read_attr_int(demo, "num_samples", where) != static_cast<int64_t>(T))
      throw Error(where + ": attribute num_samples does not match the data");
    ep.rewards = read_vector<float>(demo, "rewards", H5T_NATIVE_FLOAT, T, where, true);
    ep.dones = read_vector<uint8_t>(demo, "dones", H5T_NATIVE_UINT8, T, where, true);
    ep.intervention = read_vector<uint8_t>(demo, "intervention", H5T_NATIVE_UINT8, T, where, false);
    ep.actor = read_vector<uint8_t>(demo, "actor", H5T_NATIVE_UINT8, T, where, false);
    for (uint8_t a : ep.actor)
      if (a >= std::size(kActorLabels)) throw Error(where + ": dataset 'actor' holds " + std::to_string(a) + ", not a known actor");
    ep.success = H5Aexists(demo, "success") > 0 && read_attr_int(demo, "success", where) != 0;
    if (H5Aexists(demo, "source") > 0) ep.source = read_attr_string(demo, "source", where);
    in.total += static_cast<int64_t>(T);
    in.successes += ep.success;
    for (uint8_t f : ep.intervention) in.intervention_steps += f;
    in.obs_dim = static_cast<int>(ep.obs.cols());
    in.action_dim = static_cast<int>(ep.actions.cols());
    out.push_back(std::move(ep));
  });
  in.episodes = static_cast<int>(out.size());
  if (in.total != total)
    throw Error(path + ": attribute /data total (" + std::to_string(total) + ") does not match the episodes (" +
                std::to_string(in.total) + " steps)");
  if (info) *info = in;
  return out;
}

}  // namespace

}  // namespace dd

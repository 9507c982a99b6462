// HDF5 data sets: round trip in robomimic's layout, crash safety under kill -9, and clear errors for
// corrupt, truncated, missing and mismatched files that leave everything else in the folder alone.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "core/config.h"
#include "core/dataset.h"

namespace dd {
namespace {

namespace fs = std::filesystem;

// Episode k has 20 + k % 7 steps whose values encode (k, step), so content can be checked.
RecordedEpisode make_episode(int k) {
  const int T = 20 + k % 7;
  RecordedEpisode ep;
  ep.obs.resize(T, 4);
  ep.actions.resize(T, 2);
  for (int t = 0; t < T; ++t) {
    ep.obs.row(t) << static_cast<float>(k), static_cast<float>(t), 0.5f, -0.5f;
    ep.actions.row(t) << static_cast<float>(k * 1000 + t), 1.f;
    ep.intervention.push_back(t >= T / 2);
    ep.rewards.push_back(t == T - 1 ? 1.f : 0.f);
  }
  ep.success = k % 2 == 0;
  ep.source = "intervention";
  return ep;
}

bool episode_intact(const RecordedEpisode& ep, int k) {
  const RecordedEpisode ref = make_episode(k);
  return ep.obs == ref.obs && ep.actions == ref.actions && ep.intervention == ref.intervention && ep.success == ref.success;
}

class Dataset : public testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("dd_dataset_" + std::to_string(::getpid()) + "_" +
                                        testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string file(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST_F(Dataset, RoundTripInRobomimicLayout) {
  const std::string path = file("demos.hdf5");
  {
    DatasetWriter w(path, R"({"env_name": "nav2d"})");
    for (int k = 0; k < 3; ++k) w.append(make_episode(k));
    EXPECT_EQ(w.episodes(), 3);
  }
  DatasetInfo info;
  const auto eps = read_dataset(path, &info);
  ASSERT_EQ(eps.size(), 3u);
  for (int k = 0; k < 3; ++k) EXPECT_TRUE(episode_intact(eps[static_cast<size_t>(k)], k)) << k;
  EXPECT_EQ(info.total, 20 + 21 + 22);
  EXPECT_EQ(info.env_args, R"({"env_name": "nav2d"})");
  EXPECT_EQ(info.successes, 2);
  EXPECT_EQ(info.obs_dim, 4);
  EXPECT_EQ(eps[1].source, "intervention");

  // Reopening appends after the existing episodes.
  DatasetWriter again(path, R"({"env_name": "nav2d"})");
  EXPECT_EQ(again.episodes(), 3);
  again.append(make_episode(3));
  EXPECT_EQ(dataset_info(path).episodes, 4);

  // Only the flagged steps are expert data.
  EXPECT_EQ(eps[0].expert_steps().obs.rows(), 10);
}

TEST_F(Dataset, MismatchedEnvArgsAndBadEpisodesAreRefused) {
  const std::string path = file("demos.hdf5");
  DatasetWriter(path, R"({"env_name": "nav2d"})").append(make_episode(0));
  EXPECT_NE(message_of([&] { DatasetWriter(path, R"({"env_name": "stack"})"); }).find("env_args"), std::string::npos);
  RecordedEpisode bad = make_episode(1);
  bad.actions(3, 0) = NAN;
  DatasetWriter w(path, R"({"env_name": "nav2d"})");
  EXPECT_NE(message_of([&] { w.append(bad); }).find(path), std::string::npos);
  EXPECT_EQ(dataset_info(path).episodes, 1);  // nothing lost, nothing half-written
  EXPECT_FALSE(fs::exists(path + ".partial"));
}

TEST_F(Dataset, KillNineLosesAtMostTheEpisodeInProgress) {
  const std::string path = file("live.hdf5");
  for (int trial = 0; trial < 6; ++trial) {
    fs::remove(path);
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      try {
        DatasetWriter w(path, "{}");
        for (int k = 0;; ++k) w.append(make_episode(k));
      } catch (...) {
      }
      _exit(3);
    }
    // Let it write for a while, note how many episodes were complete, then kill it mid-stream.
    std::this_thread::sleep_for(std::chrono::milliseconds(40 + 37 * trial));
    int seen = 0;
    try {
      seen = dataset_info(path).episodes;
    } catch (const Error&) {
      // the first episode may not be on disk yet
    }
    std::this_thread::sleep_for(std::chrono::microseconds(1500 * trial + 300));
    ASSERT_EQ(kill(child, SIGKILL), 0);
    int status = 0;
    waitpid(child, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status)) << "the writer exited on its own (status " << status << ")";

    if (!fs::exists(path)) {
      EXPECT_EQ(seen, 0);
      continue;
    }
    std::vector<RecordedEpisode> eps;
    ASSERT_NO_THROW(eps = read_dataset(path)) << "trial " << trial;
    EXPECT_GE(static_cast<int>(eps.size()), seen) << "trial " << trial;
    for (size_t k = 0; k < eps.size(); ++k) EXPECT_TRUE(episode_intact(eps[k], static_cast<int>(k))) << "trial " << trial << " episode " << k;
    // The next run can go on appending to the same file.
    DatasetWriter resume(path, "{}");
    resume.append(make_episode(static_cast<int>(eps.size())));
    EXPECT_EQ(dataset_info(path).episodes, static_cast<int>(eps.size()) + 1);
  }
}

TEST_F(Dataset, CorruptTruncatedAndMissingFilesGiveClearErrors) {
  const std::string good = file("good.hdf5");
  DatasetWriter(good, "{}").append(make_episode(0));
  const auto good_size = fs::file_size(good);
  const auto good_time = fs::last_write_time(good);

  const std::string garbage = file("garbage.hdf5");
  std::ofstream(garbage) << "this is not an HDF5 file at all";
  std::string m = message_of([&] { read_dataset(garbage); });
  EXPECT_NE(m.find(garbage), std::string::npos) << m;
  EXPECT_NE(m.find("corrupt"), std::string::npos) << m;

  const std::string cut = file("cut.hdf5");
  fs::copy_file(good, cut);
  fs::resize_file(cut, good_size / 3);
  m = message_of([&] { read_dataset(cut); });
  EXPECT_NE(m.find(cut), std::string::npos) << m;

  const std::string missing = file("missing.hdf5");
  m = message_of([&] { read_dataset(missing); });
  EXPECT_NE(m.find("no such"), std::string::npos) << m;

  // Writing into a corrupt file is refused, and the corrupt file is not touched either.
  const auto garbage_size = fs::file_size(garbage);
  EXPECT_THROW(DatasetWriter(garbage, "{}"), Error);
  EXPECT_EQ(fs::file_size(garbage), garbage_size);

  EXPECT_EQ(fs::file_size(good), good_size);
  EXPECT_EQ(fs::last_write_time(good), good_time);
  EXPECT_EQ(read_dataset(good).size(), 1u);
}

// A file the fuzzer (tests/fuzz) made libhdf5 overflow its heap on: whether or not libhdf5 crashes
// on it in this build, reading it ends in an Error naming the file, and this process goes on.
TEST_F(Dataset, AFileThatCrashedLibhdf5IsAnError) {
  const std::string path = DD_SOURCE_DIR "/tests/data/fuzz_regressions/hdf5_attr_exists_overflow.hdf5";
  const std::string m = message_of([&] { read_dataset(path); });
  EXPECT_NE(m.find(path), std::string::npos) << m;
  // a header that claims a dataset of billions of rows (tests/fuzz: an allocation that aborted)
  const std::string huge = DD_SOURCE_DIR "/tests/data/fuzz_regressions/hdf5_huge_dataset_dims.hdf5";
  const std::string mh = message_of([&] { read_dataset(huge); });
  EXPECT_NE(mh.find(huge), std::string::npos) << mh;
  const std::string good = file("good.hdf5");
  DatasetWriter writer(good, "{}");
  writer.append(make_episode(0));
  writer.append(make_episode(1));
  const auto eps = read_dataset(good);  // and the next file reads as usual, whole
  ASSERT_EQ(eps.size(), 2u);
  EXPECT_TRUE(episode_intact(eps[0], 0) && episode_intact(eps[1], 1));
}

}  // namespace dd

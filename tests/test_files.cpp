// Small shared utilities: whole-file text I/O that never leaves a half-written file, and the
// progress bar's time-left estimate after a resume.
#include <gtest/gtest.h>

#include <cmath>
#include <chrono>
#include <cstdio>
#include <string>
#include <filesystem>
#include <fstream>
#include <vector>

#include <unistd.h>

#include <signal.h>

#include "core/config.h"
#include "core/isolate.h"
#include "core/progress.h"
#include "core/text_file.h"

namespace dd {
namespace fs = std::filesystem;

// A fresh folder per test, removed afterwards.
class TextFile : public testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() / ("dd_text_file_" + std::string(testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  fs::path dir;
};

TEST_F(TextFile, WritesReadsAndReplaces) {
  const std::string path = (dir / "a.json").string();
  write_text(path, "first\n");
  write_text(path, "second\n");
  EXPECT_EQ(read_text(path), "second\n");
  EXPECT_FALSE(fs::exists(path + ".tmp"));
}

TEST_F(TextFile, AFailedWriteLeavesTheOldFileAndNamesIt) {
  const std::string path = (dir / "cell.json").string();
  write_text(path, "good\n");
  fs::create_directories(temporary_path(path));  // the temporary file cannot be created
  try {
    write_text(path, "new\n");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_EQ(read_text(path), "good\n");
  EXPECT_THROW(read_text((dir / "missing.json").string()), Error);
}

TEST_F(TextFile, AFailedRenameSaysWhy) {
  const std::string path = (dir / "taken").string();
  fs::create_directories(path + "/inside");  // a folder that is not empty where the file should go
  try {
    write_text(path, "x\n");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path + ": could not move into place: "), std::string::npos) << what;
    EXPECT_EQ(what.find("Success"), std::string::npos) << "the reason was overwritten: " << what;
  }
  EXPECT_FALSE(fs::exists(temporary_path(path)));
}

TEST(ProgressBar, TimeLeftCountsOnlyTheUnitsDoneSinceTheBarStarted) {
  // 10 units in 20 s, 80 to go: 160 s
  EXPECT_DOUBLE_EQ(time_left(20, 0, 10, 90), 160);
  // resumed at 8000 of 16000, 100 fresh units in 20 s: 7900 to go at 5 a second, not 16 times faster
  EXPECT_DOUBLE_EQ(time_left(20, 8000, 8100, 16000), 1580);
  EXPECT_TRUE(std::isnan(time_left(5, 8000, 8000, 16000)));
}

TEST(ProgressBar, LinesNameEachPartOfWorkWhoseCountRestarts) {
  // an update: training to 10 steps, then a threshold pass over 20 pairs, counted from 0 again
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  {
    ProgressBar bar("update 2", "loss", f);
    bar.lines_every(0);  // a line at every update
    const ProgressFn fn = bar.fn();
    fn(5, 10, 0.5);
    fn(10, 10, 0.25);
    fn(4, 20, 0.125);
    fn(20, 20, 0.125);
    fn(3, 5, NAN);  // a count with no value to show (the ensembles' members that have sampled)
  }
  std::rewind(f);
  std::string out;
  for (int c; (c = std::fgetc(f)) != EOF;) out += static_cast<char>(c);
  std::fclose(f);
  std::vector<std::string> lines;
  for (size_t a = 0, b; (b = out.find('\n', a)) != std::string::npos; a = b + 1) lines.push_back(out.substr(a, b - a));
  ASSERT_GE(lines.size(), 5u) << out;
  EXPECT_EQ(lines[0].rfind("update 2 5/10 ( 50%)  loss 0.5  left ", 0), 0u) << lines[0];
  EXPECT_EQ(lines[1].rfind("update 2 10/10 (100%)", 0), 0u) << lines[1];
  EXPECT_NE(out.find("\nupdate 2, part 2 4/20 ( 20%)  loss 0.125  left "), std::string::npos) << out;
  EXPECT_EQ(out.find("update 2 4/20"), std::string::npos) << "the second part is named: " << out;
  EXPECT_NE(out.find("\nupdate 2, part 2 20/20 (100%)  loss 0.125  left "), std::string::npos) << out;
  EXPECT_NE(out.find("\nupdate 2, part 3 3/5 ( 60%)  left "), std::string::npos) << "no 'loss nan': " << out;
  EXPECT_EQ(out.find("nan"), std::string::npos) << out;
}

}  // namespace dd

// ---- reading in a child process (core/isolate.h) ----

TEST(ReadInChild, ReturnsWhatTheChildRead) {
  EXPECT_EQ(dd::read_in_child("x.bin", "lib", [] { return std::string("bytes\0with a zero", 17); }), std::string("bytes\0with a zero", 17));
  const std::string big(3 << 20, 'z');  // more than a pipe holds at once
  EXPECT_EQ(dd::read_in_child("x.bin", "lib", [&] { return big; }), big);
}

TEST(ReadInChild, ThrowsTheChildsMessage) {
  try {
    dd::read_in_child("x.bin", "lib", []() -> std::string { throw dd::Error("x.bin: field 'y' is wrong"); });
    FAIL() << "no error";
  } catch (const dd::Error& e) {
    EXPECT_STREQ(e.what(), "x.bin: field 'y' is wrong");
  }
}

TEST(ReadInChild, ALibraryCrashIsAnErrorNamingTheFile) {
  const int before = dd::children_crashed();
  for (const int sig : {SIGSEGV, SIGABRT}) {
    try {
      dd::read_in_child("corrupt.h5", "libhdf5", [sig]() -> std::string {
        ::signal(sig, SIG_DFL);  // (a sanitizer or a test framework may have its own handler)
        ::raise(sig);
        return "";
      });
      FAIL() << "no error";
    } catch (const dd::Error& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("corrupt.h5: the file is corrupt: reading it crashed libhdf5"), std::string::npos) << m;
      EXPECT_NE(m.find("signal " + std::to_string(sig)), std::string::npos) << m;
    }
  }
  EXPECT_EQ(dd::children_crashed(), before + 2);
}

// A child that deadlocks at once (tests/fuzz saw one blocked on ASan's allocator lock, held by
// another thread at the fork) is killed after a few seconds asleep and the read is tried again.
TEST(ReadInChild, AChildAsleepWithoutProgressIsKilledAndTheReadTriedAgain) {
  const std::string marker = (std::filesystem::temp_directory_path() / ("dd_stall_" + std::to_string(::getpid()))).string();
  std::filesystem::remove(marker);
  const auto sleep_forever = [] {
    for (;;) ::pause();
  };
  // the first child stalls; the second finds the first one's marker and reads
  EXPECT_EQ(dd::read_in_child("slow.bin", "lib",
                              [&] {
                                if (!std::filesystem::exists(marker)) {
                                  std::ofstream(marker) << "stalled once\n";
                                  sleep_forever();
                                }
                                return std::string("read on the second try");
                              }),
            "read on the second try");
  std::filesystem::remove(marker);
  // one that stalls every time is an Error naming the file and the library
  try {
    dd::read_in_child("stuck.bin", "libstuck", [&]() -> std::string {
      sleep_forever();
      return {};
    });
    FAIL() << "no error";
  } catch (const dd::Error& e) {
    EXPECT_NE(std::string(e.what()).find("stuck.bin: reading it with libstuck stalled"), std::string::npos) << e.what();
  }
}

TEST(RunInChildren, ResultsInOrderAndEveryReportDelivered) {
  for (const int concurrent : {1, 2, 5}) {
    std::vector<std::vector<std::string>> reports(5);
    const std::vector<std::string> results = dd::run_in_children(
        5, concurrent, "jobs",
        [](int i, const dd::ReportFn& report) {
          for (int k = 0; k < 3; ++k) report(std::to_string(i) + "." + std::to_string(k));
          ::usleep(static_cast<useconds_t>((5 - i) * 2000));  // finish out of order
          return std::string(static_cast<size_t>(i) * (1 << 17), static_cast<char>('a' + i));  // up to 512 KiB
        },
        [&](int i, const std::string& m) { reports[static_cast<size_t>(i)].push_back(m); });
    ASSERT_EQ(results.size(), 5u);
    for (int i = 0; i < 5; ++i) {
      EXPECT_EQ(results[static_cast<size_t>(i)], std::string(static_cast<size_t>(i) * (1 << 17), static_cast<char>('a' + i))) << i;
      const std::vector<std::string> want = {std::to_string(i) + ".0", std::to_string(i) + ".1", std::to_string(i) + ".2"};
      EXPECT_EQ(reports[static_cast<size_t>(i)], want) << "concurrent " << concurrent;
    }
  }
}

TEST(RunInChildren, AJobsErrorOrDeathStopsTheOthersAndIsAnError) {
  auto run = [](bool crash) {
    try {
      dd::run_in_children(4, 2, "training", [crash](int i, const dd::ReportFn&) -> std::string {
        if (i == 2) {
          if (!crash) throw dd::Error("member data is empty");
          ::signal(SIGSEGV, SIG_DFL);
          ::raise(SIGSEGV);
        }
        if (i == 3) ::sleep(60);  // killed, not waited for
        return "ok";
      });
    } catch (const dd::Error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(run(false), "training: job 2: member data is empty");
  const std::string died = run(true);
  EXPECT_NE(died.find("training: job 2: the child process running it died (signal " + std::to_string(SIGSEGV)), std::string::npos) << died;
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(30)) << "the sleeping job was waited for";
}

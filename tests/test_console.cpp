// The operator console through its headless platform layer (EGL, fixed time step): the named
// screenshots match the goldens in screenshots/, a script of input events takes over and hands back
// with the steps reaching the data set, and a malformed script is refused with its file and field.
//
// DD_UPDATE_GOLDENS=1 rewrites the goldens from this run (look at them before committing).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <thread>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "app/experiments.h"
#include "core/config.h"
#include "core/dataset.h"
#include "ui/commands.h"
#include "ui/console_app.h"
#include "ui/script.h"
#include "ui/image_io.h"
#include "ui/worker.h"

namespace dd::ui {
namespace {

namespace fs = std::filesystem;

std::string temp_dir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("dd_console_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  return p.string();
}

ConsoleOptions quick_options(const std::string& out, const std::string& task = "nav2d") {
  ConsoleOptions o;
  o.config = app::resolve_config(task, "");
  app::EvalOptions e;
  e.apply_quick(o.config);
  if (task != "nav2d") o.config.train.batch_size = 64;  // a screenshot test needs less than the CPU-sized preset
  o.out = out;
  o.expert_mode = "mixed";  // the goldens were recorded with the mixed pushing expert
  return o;
}

std::string read_text(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace

// Runs the headless console on `task` and compares query.png, takeover.png and update.png with
// screenshots/<task>/.
void check_goldens(const std::string& task) {
  const std::string dir = temp_dir("shots_" + task);
  ConsoleRunOptions run;
  run.screenshots = dir + "/shots";
  ConsoleOptions options = quick_options(dir + "/run", task);
  ASSERT_EQ(run_headless(options, run), 0);
  const bool regenerate = std::getenv("DD_UPDATE_GOLDENS") && std::string(std::getenv("DD_UPDATE_GOLDENS")) == "1";
  const std::string golden_dir = std::string(DD_SOURCE_DIR) + "/screenshots/" + task;
  for (const std::string name : {"update", "query", "takeover"}) {
    const std::string actual_path = run.screenshots + "/" + name + ".png";
    ASSERT_TRUE(fs::exists(actual_path)) << name;
    const Image actual = read_png(actual_path);
    EXPECT_EQ(actual.width, run.width);
    EXPECT_EQ(actual.height, run.height);
    const std::string golden = golden_dir + "/" + name + ".png";
    if (regenerate) {
      fs::create_directories(golden_dir);
      fs::copy_file(actual_path, golden, fs::copy_options::overwrite_existing);
      continue;
    }
    ASSERT_TRUE(fs::exists(golden)) << golden << " is missing: run with DD_UPDATE_GOLDENS=1 to create it";
    const ImageDiff d = compare(actual, read_png(golden), /*tolerance=*/24);
    const int budget = actual.width * actual.height / 100;  // 1% of the pixels
    const std::string failures = "screenshot_failures/" + task;
    if (d.differing > budget) {
      fs::create_directories(failures);
      write_png(failures + "/" + name + "_actual.png", actual);
      write_png(failures + "/" + name + "_diff.png", d.heat);
    }
    EXPECT_LE(d.differing, budget) << task << "/" << name << ": " << d.differing << " pixels differ (max delta " << d.max_delta
                                   << "); actual and diff in " << fs::absolute(failures).string();
  }
  // the run's data and log are on disk
  EXPECT_GE(read_dataset(dir + "/run/dataset.hdf5").size(), 3u);
  const std::string log = read_text(dir + "/run/session.jsonl");
  EXPECT_NE(log.find("\"event\":\"query\""), std::string::npos);
  EXPECT_NE(log.find("\"event\":\"update_finished\""), std::string::npos);
  fs::remove_all(dir);
}

TEST(Console, HeadlessScreenshotsMatchTheGoldensNav2d) { check_goldens("nav2d"); }
TEST(Console, HeadlessScreenshotsMatchTheGoldensStack) { check_goldens("stack"); }
TEST(Console, HeadlessScreenshotsMatchTheGoldensPush) { check_goldens("push"); }
TEST(Console, HeadlessScreenshotsMatchTheGoldensPlug) { check_goldens("plug"); }

TEST(Console, ScriptedOperatorTakesOverDrivesAndHandsBack) {
  const std::string dir = temp_dir("script");
  fs::create_directories(dir);
  const std::string script = dir + "/script.yaml";
  std::ofstream(script) << "# take over from the robot after the first update, drive right, hand back, reset\n"
                           "- {on: update, after: 3, do: take_over}\n"
                           "- {on: takeover, after: 0, hold: Right, frames: 10}\n"
                           "- {on: takeover, after: 12, do: hand_back}\n"
                           "- {on: takeover, after: 20, do: reset}\n";
  ConsoleRunOptions run;
  run.script = script;
  run.max_frames = 260;
  ASSERT_EQ(run_headless(quick_options(dir + "/run"), run), 0);
  const std::string log = read_text(dir + "/run/session.jsonl");
  EXPECT_NE(log.find("\"control\":\"operator\",\"episode\""), std::string::npos) << log.substr(0, 2000);
  EXPECT_NE(log.find("\"event\":\"takeover\""), std::string::npos);
  EXPECT_NE(log.find("\"event\":\"hand_back\""), std::string::npos);
  EXPECT_NE(log.find("\"event\":\"reset\""), std::string::npos);
  // the episode with the takeover is in the data set, operator steps flagged, robot steps not
  bool mixed = false;
  for (const RecordedEpisode& e : read_dataset(dir + "/run/dataset.hdf5")) {
    int flagged = 0;
    for (uint8_t f : e.intervention) flagged += f;
    if (e.source == "intervention" && flagged > 0 && flagged < static_cast<int>(e.intervention.size())) mixed = true;
  }
  EXPECT_TRUE(mixed);
  fs::remove_all(dir);
}

TEST(Console, OperatorDrivesTheArmAndTogglesTheGripper) {
  const std::string dir = temp_dir("arm");
  fs::create_directories(dir);
  const std::string script = dir + "/script.yaml";
  std::ofstream(script) << "- {on: update, after: 3, key: T}\n"
                           "- {on: takeover, after: 1, hold: Up, frames: 12}\n"
                           "- {on: takeover, after: 14, key: G}\n"
                           "- {on: takeover, after: 20, key: R}\n";
  ConsoleRunOptions run;
  run.script = script;
  run.max_frames = 260;
  ConsoleOptions options = quick_options(dir + "/run", "stack");
  options.pause_on_query = false;  // a query must not stand in for the takeover
  ASSERT_EQ(run_headless(options, run), 0);
  // the operator's steps are in the data set: the TCP target moved and the gripper command changed
  bool found = false;
  for (const RecordedEpisode& e : read_dataset(dir + "/run/dataset.hdf5")) {
    if (e.source != "intervention") continue;
    std::vector<Eigen::Index> rows;
    for (size_t t = 0; t < e.intervention.size(); ++t)
      if (e.intervention[t]) rows.push_back(static_cast<Eigen::Index>(t));
    if (rows.size() < 15) continue;
    const double moved = (e.actions.row(rows.back()).head(3) - e.actions.row(rows.front()).head(3)).norm();
    float grip_min = 1, grip_max = 0;
    for (Eigen::Index r : rows) {
      grip_min = std::min(grip_min, e.actions(r, 9));
      grip_max = std::max(grip_max, e.actions(r, 9));
    }
    // 12 jog frames of 1 cm; the target keeps within 8 cm of the TCP, so an arm that meets the cubes
    // on the way lets it go less far
    EXPECT_GT(moved, 0.03) << "the jogged TCP target should have moved several cm";
    EXPECT_GT(grip_max - grip_min, 0.5f) << "G should have toggled the gripper command";
    found = true;
  }
  EXPECT_TRUE(found) << "no operator intervention in the data set";
  fs::remove_all(dir);
}

TEST(Console, MalformedScriptNamesTheFileAndTheField) {
  const std::string dir = temp_dir("bad");
  fs::create_directories(dir);
  const std::string script = dir + "/bad.yaml";
  std::ofstream(script) << "- {at: 3, key: T}\n- {at: 5, kee: H}\n";
  ConsoleRunOptions run;
  run.script = script;
  try {
    run_headless(quick_options(dir + "/run"), run);
    FAIL() << "a malformed script was accepted";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(script), std::string::npos) << what;
    EXPECT_NE(what.find("event 2"), std::string::npos) << what;
    EXPECT_NE(what.find("kee"), std::string::npos) << what;
  }
  EXPECT_FALSE(fs::exists(dir + "/run/dataset.hdf5"));  // refused before anything was written
  fs::remove_all(dir);
}

TEST(ConsoleCommands, OneTableBindsEveryCommandAndTheHelpIsMadeFromIt) {
  std::set<std::string> names;
  std::set<int> keys;
  for (int i = 0; i <= static_cast<int>(Command::kBack); ++i) {
    const Command c = static_cast<Command>(i);
    const Binding& b = binding(c);  // throws when a command has no row
    EXPECT_TRUE(names.insert(b.name).second) << "two commands named " << b.name;
    EXPECT_FALSE(b.keys.empty()) << b.name << " has no key";
    for (int k : b.keys) {
      EXPECT_TRUE(keys.insert(k).second) << "key " << k << " is bound twice";
      EXPECT_EQ(command_for_key(k), c);
    }
    EXPECT_EQ(command_named(b.name, "test"), c);
  }
  // a held key repeats only where that makes sense (single steps), never taking over again
  EXPECT_EQ(command_for_key(binding(Command::kStep).keys.front(), /*repeat=*/true), Command::kStep);
  EXPECT_FALSE(command_for_key(binding(Command::kTakeOver).keys.front(), /*repeat=*/true));
  // the help lists every row, commands and continuous inputs alike
  const auto help = console_keys();
  ASSERT_EQ(help.size(), bindings().size());
  for (size_t i = 0; i < help.size(); ++i) EXPECT_EQ(help[i].second, bindings()[i].description);
  EXPECT_EQ(command_for_key_name("T", "test"), Command::kTakeOver);
  EXPECT_EQ(command_for_key_name("Plus", "test"), Command::kFaster);
  // the README's key table (from "| key | does |" to the blank line) and its list of script commands
  // name every command's keys and name
  const std::string readme = read_text(std::string(DD_SOURCE_DIR) + "/README.md");
  const size_t table = readme.find("| key | does |");
  ASSERT_NE(table, std::string::npos);
  const std::string keys_table = readme.substr(table, readme.find("\n\n", table) - table);
  const size_t list = readme.find("the commands are");
  ASSERT_NE(list, std::string::npos);
  const std::string command_list = readme.substr(list, readme.find("holds are", list) - list);
  for (const Binding& b : bindings()) {
    if (!b.command) continue;
    EXPECT_NE(keys_table.find(b.keys_label), std::string::npos) << "README's key table lacks " << b.keys_label;
    EXPECT_NE(command_list.find(b.name), std::string::npos) << "README's script commands lack " << b.name;
  }
}

TEST(ConsoleCommands, ScriptsNameCommandsOrKeys) {
  const std::string dir = temp_dir("commands");
  fs::create_directories(dir);
  const std::string script = dir + "/script.yaml";
  std::ofstream(script) << "- {on: query, after: 8, do: take_over}\n- {at: 3, key: H}\n- {at: 4, hold: Left, frames: 2}\n";
  const auto events = load_script(script);
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[0].command, Command::kTakeOver);
  EXPECT_EQ(events[1].command, Command::kHandBack);
  EXPECT_FALSE(events[2].command);
  for (const auto& [text, expected] : std::vector<std::pair<std::string, std::string>>{
           {"- {at: 1, do: fly}\n", "unknown command 'fly' (take_over, "},
           {"- {at: 1, key: Q}\n", "key 'Q' does nothing"},
           {"- {at: 1, do: reset, key: R}\n", "give one of 'do'"}}) {
    std::ofstream(script) << text;
    try {
      load_script(script);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(script + ": event 1"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  }
  fs::remove_all(dir);
}

}  // namespace dd::ui

// The console's worker: a job's result is applied by collect() on the calling (frame) thread, only
// after the job finished; a job that throws leaves its message and applies nothing.
TEST(ConsoleWorker, ResultsAreAppliedOnTheFrameThreadAfterTheJob) {
  dd::ui::Worker worker;
  const std::thread::id frame_thread = std::this_thread::get_id();
  std::thread::id applied_on;
  int value = 0;
  std::atomic<bool> release{false};
  worker.start(dd::ui::WorkerJob::kField, [&](std::atomic<float>& progress) -> dd::ui::Worker::Apply {
    progress = 0.5f;
    while (!release) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    const int computed = 42;  // the worker's own local
    return [&, computed] {
      value = computed;
      applied_on = std::this_thread::get_id();
    };
  });
  EXPECT_TRUE(worker.busy());
  EXPECT_EQ(worker.collect(), dd::ui::WorkerJob::kNone);  // still running: nothing applied
  EXPECT_EQ(value, 0);
  release = true;
  EXPECT_EQ(worker.collect(/*wait=*/true), dd::ui::WorkerJob::kField);
  EXPECT_EQ(value, 42);
  EXPECT_EQ(applied_on, frame_thread);
  EXPECT_FALSE(worker.busy());
  EXPECT_FLOAT_EQ(worker.progress(), 0.5f);

  worker.start(dd::ui::WorkerJob::kUpdate, [](std::atomic<float>&) -> dd::ui::Worker::Apply { throw dd::Error("training failed"); });
  EXPECT_EQ(worker.collect(true), dd::ui::WorkerJob::kUpdate);
  EXPECT_EQ(worker.error(), "training failed");
  EXPECT_STREQ(dd::ui::to_string(dd::ui::WorkerJob::kUpdate), "policy update");
}

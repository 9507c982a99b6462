// Every camera of every arm scene renders headless (EGL) at a small size with the cheap settings, and
// shows something: not one flat colour, and the task's objects in view of the cameras that should see
// them.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "envs/mujoco/arm_env.h"
#include "core/config.h"
#include "envs/registry.h"
#include "ui/mujoco_view.h"

namespace dd::ui {
namespace {

double stddev(const Image& img) {
  double sum = 0, sq = 0;
  const size_t n = img.rgba.size() / 4;
  for (size_t i = 0; i < n; ++i) {
    const double g = (img.rgba[4 * i] + img.rgba[4 * i + 1] + img.rgba[4 * i + 2]) / 3.0;
    sum += g;
    sq += g * g;
  }
  const double m = sum / n;
  return std::sqrt(std::max(sq / n - m * m, 0.0));
}

// Pixels that are clearly the given hue (red, green or blue dominant).
int hue_pixels(const Image& img, int channel) {
  int count = 0;
  for (size_t i = 0; i + 3 < img.rgba.size(); i += 4) {
    const int c = img.rgba[i + channel], o1 = img.rgba[i + (channel + 1) % 3], o2 = img.rgba[i + (channel + 2) % 3];
    if (c > 120 && c > o1 + 60 && c > o2 + 60) ++count;
  }
  return count;
}

}  // namespace

TEST(MujocoRender, EveryCameraOfEverySceneShowsTheTask) {
  const std::map<std::string, std::vector<std::string>> expected = {
      {"stack", {"left", "right", "wrist", "overview"}}, {"push", {"top", "overview", "wrist"}}, {"plug", {"left", "right", "wrist", "overview"}}};
  for (const auto& [task, cameras] : expected) {
    auto env = make_env(task);
    env->reset(5);
    auto* arm = dynamic_cast<mj::ArmEnv*>(env.get());
    ASSERT_NE(arm, nullptr);
    std::vector<std::pair<std::string, Image>> images;
    try {
      images = render_all_cameras(arm->model(), arm->data(), 96);
    } catch (const Error& e) {
      GTEST_SKIP() << "no headless GL here: " << e.what();
    }
    std::map<std::string, Image> by_name(images.begin(), images.end());
    for (const std::string& cam : cameras) {
      ASSERT_TRUE(by_name.count(cam)) << task << " has no camera " << cam;
      const Image& img = by_name[cam];
      EXPECT_EQ(img.width, 96);
      EXPECT_GT(stddev(img), 8.0) << task << "/" << cam << " is (nearly) one flat colour";
    }
    // the objects are in view of the scene cameras
    if (task == "stack") {
      for (const char* cam : {"left", "right"}) {
        EXPECT_GT(hue_pixels(by_name[cam], 0), 3) << "red cube not seen by " << cam;
        EXPECT_GT(hue_pixels(by_name[cam], 1), 3) << "green cube not seen by " << cam;
      }
    } else if (task == "push") {
      EXPECT_GT(hue_pixels(by_name["top"], 2), 20) << "the T-block is not seen from the top camera";
    } else {
      for (const char* cam : {"left", "right"}) EXPECT_GT(hue_pixels(by_name[cam], 2), 3) << "receptacle not seen by " << cam;
    }
  }
}

}  // namespace dd::ui

// diffdagger render: a task's scene from each of its cameras (and the console's free camera), as PNG,
// headless. For looking at a scene, and at what a camera observation sees.
#include <spdlog/spdlog.h>

#include <filesystem>

#include "app/commands.h"
#include "core/config.h"
#include "envs/mujoco/arm_env.h"
#include "envs/registry.h"
#include "ui/headless_gl.h"
#include "ui/mujoco_view.h"

namespace dd::app {

Command add_render(CLI::App& app) {
  auto* cmd = app.add_subcommand("render", "Render a MuJoCo task's cameras to PNG files (headless)");
  struct Opts {
    std::string task = "stack", out;
    uint64_t seed = 0;
    int size = 96, steps = 0;
  };
  auto o = std::make_shared<Opts>();
  cmd->add_option("--task", o->task, "task: stack, push, plug")->capture_default_str();
  cmd->add_option("--out", o->out, "output folder")->required();
  cmd->add_option("--seed", o->seed, "episode seed")->capture_default_str();
  cmd->add_option("--size", o->size, "camera image size [px]")->capture_default_str();
  cmd->add_option("--expert-steps", o->steps, "let the expert act this many steps first")->capture_default_str();
  return [o] {
    auto env = make_env(o->task);
    auto* arm = dynamic_cast<mj::ArmEnv*>(env.get());
    if (!arm) throw Error("render: task '" + o->task + "' is not a MuJoCo task");
    env->reset(o->seed);
    auto expert = make_expert(o->task, "mixed");
    expert->reset(o->seed);
    for (int i = 0; i < o->steps && !env->step(expert->act(*env)).done; ++i) {
    }
    std::filesystem::create_directories(o->out);
    std::string error;
    auto gl = ui::HeadlessGL::create(64, 64, &error);
    if (!gl) throw Error(error);
    ui::MujocoView view(arm->model());
    for (const std::string& name : view.camera_names()) {
      const std::string path = o->out + "/" + o->task + "_" + name + ".png";
      ui::write_png(path, view.camera(arm->data(), name, o->size, o->size, true));
      spdlog::info("{}", path);
    }
    const std::string path = o->out + "/" + o->task + "_free.png";
    ui::write_png(path, view.free(arm->data(), ui::FreeCamera{}, 640, 480));
    spdlog::info("{}", path);
    return 0;
  };
}

}  // namespace dd::app

// diffdagger render: a task's scene from each of its cameras (and the console's free camera), as PNG,
// headless. For looking at a scene, and at what a camera observation sees.
#include <spdlog/spdlog.h>

#include <filesystem>

#include "app/commands.h"
#include "core/config.h"
#include "core/policy.h"
#include "ui/plot.h"
#include "envs/mujoco/arm_env.h"
#include "envs/registry.h"
#include "ui/headless_gl.h"
#include "ui/mujoco_view.h"

namespace dd::app {

Command add_render(CLI::App& app) {
  auto* cmd = app.add_subcommand("render", "Render a MuJoCo task's cameras to PNG files (headless)");
  struct Opts {
    std::string task = "stack", out, policy;
    uint64_t seed = 0;
    int size = 96, steps = 0, every = 0;
  };
  auto o = std::make_shared<Opts>();
  cmd->add_option("--task", o->task, "task: stack, push, plug")->capture_default_str();
  cmd->add_option("--out", o->out, "output folder")->required();
  cmd->add_option("--seed", o->seed, "episode seed")->capture_default_str();
  cmd->add_option("--size", o->size, "camera image size [px]")->capture_default_str();
  cmd->add_option("--expert-steps", o->steps, "let the expert act this many steps first")->capture_default_str();
  cmd->add_option("--policy", o->policy, "a checkpoint: roll it out from the seed and film it (with --every)");
  cmd->add_option("--every", o->every, "with --policy: a free-camera frame every this many steps, and a strip of them")
      ->capture_default_str();
  return [o] {
    auto env = make_env(o->task);
    const std::optional<PhysicsScene> physics = env->physics();
    if (!physics) throw Error("render: task '" + o->task + "' is not a MuJoCo task");
    env->reset(o->seed);
    auto expert = make_expert(o->task, "mixed");
    expert->reset(o->seed);
    for (int i = 0; i < o->steps && !env->step(expert->act(*env)).done; ++i) {
    }
    std::filesystem::create_directories(o->out);
    std::string error;
    auto gl = ui::HeadlessGL::create(64, 64, &error);
    if (!gl) throw Error(error);
    ui::MujocoView view(physics->model);
    if (!o->policy.empty()) {
      // film a rollout of the policy: the executed chunk's T_a actions per decision, like evaluation
      auto policy = DiffusionPolicy::from_checkpoint(o->policy);
      if (policy->config().obs_dim != env->obs_dim() || policy->config().action_dim != env->action_dim())
        throw Error(o->policy + ": a policy for observations " + std::to_string(policy->config().obs_dim) + " and actions " +
                    std::to_string(policy->config().action_dim) + ", not task " + o->task);
      env->reset(o->seed);
      const int every = std::max(1, o->every);
      std::vector<ui::Image> strip;
      bool done = false;
      for (uint64_t decision = 0; !done; ++decision) {
        const Mat chunk = policy->sample(env->observation(), o->seed * 7919 + decision);
        for (int k = 0; k < policy->config().action_steps && !done; ++k) {
          if (env->steps() % every == 0) {
            ui::Image frame = view.free(physics->data, ui::FreeCamera{}, 320, 240);
            ui::write_png(o->out + "/" + o->task + "_step" + std::to_string(env->steps()) + ".png", frame);
            if (strip.size() < 12) strip.push_back(std::move(frame));
          }
          done = env->step(chunk.row(k).transpose()).done;
        }
      }
      const std::string path = o->out + "/" + o->task + "_rollout.png";
      ui::write_png(path, ui::hstack(strip, "seed " + std::to_string(o->seed) + ": " + env->outcome() + " after " +
                                                std::to_string(env->steps()) + " steps (frames every " + std::to_string(every) + ")"));
      spdlog::info("{}: {}", path, env->outcome());
      return 0;
    }
    for (const std::string& name : view.camera_names()) {
      const std::string path = o->out + "/" + o->task + "_" + name + ".png";
      ui::write_png(path, view.camera(physics->data, name, o->size, o->size, true));
      spdlog::info("{}", path);
    }
    const std::string path = o->out + "/" + o->task + "_free.png";
    ui::write_png(path, view.free(physics->data, ui::FreeCamera{}, 640, 480));
    spdlog::info("{}", path);
    return 0;
  };
}

}  // namespace dd::app

// What a plugging policy does at the socket: rolls a checkpoint out from a seed (T_a steps of each
// sampled chunk) and prints, every 10 steps while the charger is within 3 cm of the socket, the
// charger's offset from the socket's centre, its height over the seated height, its tilt, the
// commanded TCP position minus the actual one, the gripper command, and the TCP-to-charger distance
// (about 4 mm in the expert's grasp). Then the episode's outcome.
//   build/tests/bench/plug_trace CHECKPOINT [seed=950000]
#include <cmath>
#include <cstdio>
#include <string>

#include "core/policy.h"
#include "core/runtime.h"
#include "envs/mujoco/mj_util.h"
#include "envs/mujoco/plug.h"

int main(int argc, char** argv) {
  using namespace dd;
  using namespace dd::mj;
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s CHECKPOINT [seed=950000]\n", argv[0]);
    return 2;
  }
  set_num_threads();
  const auto policy = DiffusionPolicy::from_checkpoint(argv[1]);
  const uint64_t seed = argc > 2 ? std::stoull(argv[2]) : 950000;
  PlugEnv env;
  env.reset(seed);
  const int charger = mj_name2id(env.model(), mjOBJ_BODY, "charger");
  const int steps = policy->config().action_steps;
  Mat chunk;
  std::printf("step  off-centre  over-seated   tilt   command-TCP x, y, z [mm]   grip  TCP-charger\n");
  for (int t = 0; t < env.time_limit(); ++t) {
    const Vec o = env.observation();
    if (t % steps == 0) chunk = policy->sample(o, seed * 1000 + static_cast<uint64_t>(t));
    const Vec a = chunk.row(t % steps).transpose();
    const Eigen::Vector3d c = env.charger_pos(), s = env.socket_pos(), tcp = env.arm().tcp_pos(env.data());
    const double tilt = std::acos(std::min(1.0, free_quat(env.model(), env.data(), charger).toRotationMatrix()(2, 2))) * 180 / M_PI;
    if (t % 10 == 0 && (c - s).head<2>().norm() < 0.03)
      std::printf("%4d  %7.1f mm  %8.1f mm  %5.1f  %7.1f %6.1f %6.1f        %.2f  %6.1f mm\n", t, (c - s).head<2>().norm() * 1000,
                  (c.z() - env.seated_height()) * 1000, tilt, (a[0] - tcp.x()) * 1000, (a[1] - tcp.y()) * 1000, (a[2] - tcp.z()) * 1000, a[9],
                  (tcp - c).norm() * 1000);
    if (env.step(a).done) break;
  }
  std::printf("%s\n", env.outcome().c_str());
  return 0;
}

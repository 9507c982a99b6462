// A sampling-based path planner for the tool centre point: RRT-Connect in a box of free space around
// axis-aligned box obstacles, then shortcutting. The experts plan their transit moves with it (over
// the other object, out of the table) and fall back to a raised straight path when it fails.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace dd::mj {

struct Box3 {
  Eigen::Vector3d lo, hi;
  bool contains(const Eigen::Vector3d& p) const { return (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all(); }
};

struct PlannerConfig {
  Box3 bounds{{0.15, -0.45, 0.02}, {0.85, 0.45, 0.50}};  // where the TCP may go [m]
  double step = 0.04;          // tree extension [m]
  double resolution = 0.005;   // collision checking along segments [m]
  int max_iterations = 3000;
};

/// A collision-free polyline from `from` to `to` (both included), or empty when none was found.
/// Deterministic for a given seed.
std::vector<Eigen::Vector3d> plan_path(const Eigen::Vector3d& from, const Eigen::Vector3d& to, const std::vector<Box3>& obstacles,
                                       uint64_t seed, const PlannerConfig& config = {});

/// True if the segment a-b stays clear of every obstacle and inside the bounds.
bool segment_free(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const std::vector<Box3>& obstacles, const PlannerConfig& config);

}  // namespace dd::mj

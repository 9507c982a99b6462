#include "envs/mujoco/planner.h"

#include <random>

namespace dd::mj {

bool segment_free(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const std::vector<Box3>& obstacles, const PlannerConfig& c) {
  const int n = std::max(1, static_cast<int>((b - a).norm() / c.resolution));
  for (int i = 0; i <= n; ++i) {
    const Eigen::Vector3d p = a + (b - a) * (double(i) / n);
    if (!c.bounds.contains(p)) return false;
    for (const Box3& o : obstacles)
      if (o.contains(p)) return false;
  }
  return true;
}

namespace {

struct Tree {
  std::vector<Eigen::Vector3d> nodes;
  std::vector<int> parent;
  int nearest(const Eigen::Vector3d& p) const {
    int best = 0;
    double d = 1e18;
    for (size_t i = 0; i < nodes.size(); ++i) {
      const double e = (nodes[i] - p).squaredNorm();
      if (e < d) d = e, best = static_cast<int>(i);
    }
    return best;
  }
  std::vector<Eigen::Vector3d> path_to_root(int i) const {
    std::vector<Eigen::Vector3d> out;
    for (; i >= 0; i = parent[static_cast<size_t>(i)]) out.push_back(nodes[static_cast<size_t>(i)]);
    return out;
  }
};

// Extends `t` from its node nearest to `target` by at most one step; returns the new node or -1.
int extend(Tree& t, const Eigen::Vector3d& target, const std::vector<Box3>& obs, const PlannerConfig& c) {
  const int n = t.nearest(target);
  const Eigen::Vector3d& from = t.nodes[static_cast<size_t>(n)];
  Eigen::Vector3d to = target;
  if ((to - from).norm() > c.step) to = from + (to - from).normalized() * c.step;
  if (!segment_free(from, to, obs, c)) return -1;
  t.nodes.push_back(to);
  t.parent.push_back(n);
  return static_cast<int>(t.nodes.size()) - 1;
}

}  // namespace

std::vector<Eigen::Vector3d> plan_path(const Eigen::Vector3d& from, const Eigen::Vector3d& to, const std::vector<Box3>& obstacles,
                                       uint64_t seed, const PlannerConfig& c) {
  if (segment_free(from, to, obstacles, c)) return {from, to};
  Tree a{{from}, {-1}}, b{{to}, {-1}};
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Eigen::Vector3d> path;
  for (int it = 0; it < c.max_iterations && path.empty(); ++it) {
    const Eigen::Vector3d q = c.bounds.lo + (c.bounds.hi - c.bounds.lo).cwiseProduct(Eigen::Vector3d(u(rng), u(rng), u(rng)));
    const int na = extend(a, q, obstacles, c);
    if (na >= 0) {
      // connect: grow the other tree towards the new node until blocked or joined
      const Eigen::Vector3d target = a.nodes[static_cast<size_t>(na)];
      int nb = -1;
      for (;;) {
        const int next = extend(b, target, obstacles, c);
        if (next < 0) break;
        nb = next;
        if ((b.nodes[static_cast<size_t>(nb)] - target).norm() < 1e-9) {
          auto pa = a.path_to_root(na), pb = b.path_to_root(nb);
          const bool a_is_start = (a.nodes[0] - from).norm() < 1e-12;
          std::reverse(pa.begin(), pa.end());
          pa.insert(pa.end(), pb.begin() + 1, pb.end());
          if (!a_is_start) std::reverse(pa.begin(), pa.end());
          path = std::move(pa);
          break;
        }
      }
    }
    std::swap(a, b);
  }
  if (path.empty()) return {};
  // shortcut: from each point jump to the farthest point visible from it
  std::vector<Eigen::Vector3d> out{path.front()};
  size_t i = 0;
  while (i + 1 < path.size()) {
    size_t j = path.size() - 1;
    while (j > i + 1 && !segment_free(path[i], path[j], obstacles, c)) --j;
    out.push_back(path[j]);
    i = j;
  }
  return out;
}

}  // namespace dd::mj

#include "envs/nav2d.h"

#include <box2d/box2d.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <random>

#include "core/config.h"
#include "envs/nav2d_expert.h"

namespace dd {

Nav2dEnv::Nav2dEnv(Nav2dConfig config) : config_(std::move(config)) { reset(0); }

Nav2dEnv::~Nav2dEnv() = default;

Nav2dConfig nav2d_random_config() {
  Nav2dConfig c;
  c.obstacle_jitter = 0.2;
  c.observe_obstacle = true;
  return c;
}

void Nav2dEnv::reset(uint64_t seed) {
  // A fresh world per episode: Box2D keeps contact caches, and a rebuilt world makes every episode
  // depend on its seed alone.
  world_ = std::make_unique<b2World>(b2Vec2(0.f, 0.f));
  b2BodyDef ground_def;
  b2Body* ground = world_->CreateBody(&ground_def);
  const float h = static_cast<float>(config_.arena_half);
  const b2Vec2 corners[4] = {{-h, -h}, {h, -h}, {h, h}, {-h, h}};
  b2ChainShape walls;
  walls.CreateLoop(corners, 4);
  ground->CreateFixture(&walls, 0.f);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-config_.start_half, config_.start_half);
  obstacle_center_ = Vec2::Zero();
  if (config_.obstacle_jitter > 0) {
    std::uniform_real_distribution<double> j(-config_.obstacle_jitter, config_.obstacle_jitter);
    obstacle_center_ = Vec2(j(rng), j(rng));
  }
  b2CircleShape obstacle;
  obstacle.m_radius = static_cast<float>(config_.obstacle_radius);
  obstacle.m_p.Set(static_cast<float>(obstacle_center_.x()), static_cast<float>(obstacle_center_.y()));
  ground->CreateFixture(&obstacle, 0.f);

  const double x = config_.start_center.x() + u(rng), y = config_.start_center.y() + u(rng);
  b2BodyDef agent_def;
  agent_def.type = b2_dynamicBody;
  agent_def.fixedRotation = true;
  agent_def.bullet = true;
  agent_def.position.Set(static_cast<float>(x), static_cast<float>(y));
  agent_ = world_->CreateBody(&agent_def);
  b2CircleShape disc;
  disc.m_radius = static_cast<float>(config_.agent_radius);
  b2FixtureDef fixture;
  fixture.shape = &disc;
  fixture.density = 1.f;
  fixture.friction = 0.f;
  fixture.restitution = 0.f;
  agent_->CreateFixture(&fixture);
  steps_ = 0;
  limit_ = config_.time_limit;
  success_ = false;
  failed_ = false;
}

Vec2 Nav2dEnv::position() const {
  const b2Vec2 p = agent_->GetPosition();
  return {p.x, p.y};
}

Vec2 Nav2dEnv::velocity() const {
  const b2Vec2 v = agent_->GetLinearVelocity();
  return {v.x, v.y};
}

Vec Nav2dEnv::observation() const { return observe(position(), velocity()); }

Vec Nav2dEnv::observe(const Vec2& p, const Vec2& v) const {
  Vec o(obs_dim());
  o.head(4) << static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(v.x()), static_cast<float>(v.y());
  if (config_.observe_obstacle) o.tail(2) << static_cast<float>(obstacle_center_.x()), static_cast<float>(obstacle_center_.y());
  return o;
}

std::optional<PlaneScene> Nav2dEnv::plane() const {
  PlaneScene s;
  s.half = config_.arena_half;
  s.start_center = config_.start_center;
  s.start_half = config_.start_half;
  s.goal = {config_.goal, config_.goal_radius};
  s.obstacles = {{obstacle_center_, config_.obstacle_radius}};
  s.agent = {position(), config_.agent_radius};
  return s;
}

std::vector<Eigen::Vector3d> Nav2dEnv::action_points(const Mat& chunk) const {
  std::vector<Eigen::Vector3d> points;
  if (chunk.cols() < 2) return points;
  for (Eigen::Index r = 0; r < chunk.rows(); ++r) points.emplace_back(chunk(r, 0), chunk(r, 1), 0.0);
  return points;
}

std::optional<Eigen::Vector3d> Nav2dEnv::observed_point(const Vec& obs) const {
  if (obs.size() < 2) return std::nullopt;
  return Eigen::Vector3d(obs[0], obs[1], 0.0);
}

std::optional<Vec> Nav2dEnv::observation_at_rest(const Vec2& p) const {
  if (!is_free(p)) return std::nullopt;
  return observe(p, Vec2::Zero());
}

StepResult Nav2dEnv::step(const Vec& action) {
  StepResult r;
  if (success_ || failed_ || steps_ >= limit_) {
    r.done = true;
    r.success = success_;
    r.failed = failed_;
    return r;
  }
  if (action.size() != 2 || !action.allFinite()) {
    failed_ = true;
    r.done = r.failed = true;
    r.warning = "nav2d: non-finite or malformed action at step " + std::to_string(steps_) + "; episode failed";
    spdlog::warn("{}", r.warning);
    return r;
  }
  const Vec2 target(action[0], action[1]);
  Vec2 v = config_.gain * (target - position());
  if (v.norm() > config_.max_speed) v *= config_.max_speed / v.norm();
  agent_->SetLinearVelocity(b2Vec2(static_cast<float>(v.x()), static_cast<float>(v.y())));
  const float dt = static_cast<float>(1.0 / config_.hz / config_.substeps);
  for (int i = 0; i < config_.substeps; ++i) world_->Step(dt, 8, 3);
  ++steps_;

  const Vec2 p = position();
  if (!p.allFinite() || p.cwiseAbs().maxCoeff() > 2 * config_.arena_half) {
    failed_ = true;
    r.done = r.failed = true;
    r.warning = "nav2d: simulation went unstable at step " + std::to_string(steps_) + "; episode failed";
    spdlog::warn("{}", r.warning);
    return r;
  }
  success_ = (p - config_.goal).norm() < config_.goal_radius;
  r.success = success_;
  r.done = success_ || steps_ >= limit_;
  return r;
}

std::vector<double> Nav2dEnv::save_state() const {
  const Vec2 p = position(), v = velocity();
  return {p.x(), p.y(), v.x(), v.y(), static_cast<double>(steps_), success_ ? 1.0 : 0.0, failed_ ? 1.0 : 0.0};
}

void Nav2dEnv::restore_state(const std::vector<double>& s) {
  if (s.size() != 7) throw Error("nav2d: a saved state has 7 values, got " + std::to_string(s.size()));
  set_agent({s[0], s[1]}, {s[2], s[3]});
  steps_ = static_cast<int>(s[4]);
  success_ = s[5] != 0.0;
  failed_ = s[6] != 0.0;
}

void Nav2dEnv::set_agent(const Vec2& position, const Vec2& velocity) {
  agent_->SetTransform(b2Vec2(static_cast<float>(position.x()), static_cast<float>(position.y())), 0.f);
  agent_->SetLinearVelocity(b2Vec2(static_cast<float>(velocity.x()), static_cast<float>(velocity.y())));
  agent_->SetAwake(true);
}

bool Nav2dEnv::is_free(const Vec2& p) const {
  const double r = config_.agent_radius;
  return (p - obstacle_center_).norm() > config_.obstacle_radius + r && p.cwiseAbs().maxCoeff() < config_.arena_half - r;
}

std::string region_name(Nav2dRegion r) {
  switch (r) {
    case Nav2dRegion::kUniModal: return "id_um";
    case Nav2dRegion::kMultiModal: return "id_mm";
    case Nav2dRegion::kOutOfDistribution: return "ood";
    case Nav2dRegion::kNone: return "none";
  }
  return "?";
}

Nav2dRegions::Nav2dRegions(const Nav2dConfig& config) : config_(config), probe_(config) {
  for (int mode = 0; mode < 2; ++mode) {
    Nav2dExpert expert(mode == 0 ? Nav2dExpert::Mode::kClockwise : Nav2dExpert::Mode::kCounterClockwise, config);
    probe_.reset(0);
    probe_.set_agent(config.start_center, Vec2::Zero());
    std::vector<Vec2>& path = mode == 0 ? cw_ : ccw_;
    path.push_back(probe_.position());
    for (int i = 0; i < config.time_limit; ++i) {
      if (probe_.step(expert.act(probe_)).done) break;
      path.push_back(probe_.position());
    }
  }
}

static double segment_distance(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

double Nav2dRegions::path_distance(const Vec2& p) const {
  double best = INFINITY;
  for (const auto* path : {&cw_, &ccw_})
    for (size_t i = 1; i < path->size(); ++i) best = std::min(best, segment_distance(p, (*path)[i - 1], (*path)[i]));
  return best;
}

Nav2dRegion Nav2dRegions::label(const Vec2& p) const {
  const double d_start = (p - config_.start_center).norm();
  if (d_start < mm_radius) return Nav2dRegion::kMultiModal;
  const double d = path_distance(p);
  if (d < um_radius) return Nav2dRegion::kUniModal;
  if (d > ood_distance && d_start > ood_distance && probe_.is_free(p)) return Nav2dRegion::kOutOfDistribution;
  return Nav2dRegion::kNone;
}

namespace {

class Nav2dTeleoperation : public Teleoperation {
 public:
  void begin() override {}
  Vec action(const Env& env, const OperatorInput& in) override {
    const Vec obs = env.observation();  // the position comes first in both observation layouts
    const Eigen::Vector2d p(obs[0], obs[1]);
    target_ = in.has_target ? in.target : Eigen::Vector2d(p + 0.2 * in.jog);
    return Vec(target_.cast<float>());
  }
  std::optional<Eigen::Vector3d> target() const override { return Eigen::Vector3d(target_.x(), target_.y(), 0); }

 private:
  Eigen::Vector2d target_{0, 0};
};

}  // namespace

std::unique_ptr<Teleoperation> Nav2dEnv::teleoperation() const { return std::make_unique<Nav2dTeleoperation>(); }

}  // namespace dd

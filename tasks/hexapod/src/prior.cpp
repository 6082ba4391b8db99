// The hexapod prior mean function and its simulator pool (prior.hpp). No DART include here.

#include "drops/hexapod/prior.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <thread>

#include "drops/core/errors.hpp"

namespace drops::hexapod {

// ---- SimulatorPool ----

SimulatorPool::Lease::Lease(SimulatorPool* pool, std::unique_ptr<PriorSimulator> sim)
    : pool_(pool), sim_(std::move(sim)) {}

SimulatorPool::Lease::Lease(Lease&& other) noexcept
    : pool_(other.pool_), sim_(std::move(other.sim_)) {
  other.pool_ = nullptr;
}

SimulatorPool::Lease& SimulatorPool::Lease::operator=(Lease&& other) noexcept {
  if (this != &other) {
    release();
    pool_ = other.pool_;
    sim_ = std::move(other.sim_);
    other.pool_ = nullptr;
  }
  return *this;
}

SimulatorPool::Lease::~Lease() { release(); }

void SimulatorPool::Lease::release() {
  if (pool_ != nullptr && sim_) pool_->give_back(std::move(sim_));
  pool_ = nullptr;
}

SimulatorPool::SimulatorPool(const HexapodSpec& spec, const PriorOptions& options, int capacity)
    : spec_(spec), options_(options), capacity_(capacity) {
  spec_.check();
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument(why);
  if (capacity < 0) {
    throw InvalidArgument("SimulatorPool: capacity must be >= 0 (0: hardware threads), got " +
                          std::to_string(capacity));
  }
  if (capacity_ == 0) capacity_ = std::max(1u, std::thread::hardware_concurrency());
}

SimulatorPool::Lease SimulatorPool::acquire() {
  std::unique_lock<std::mutex> lock(mutex_);
  available_.wait(lock, [&] { return !free_.empty() || created_ < capacity_; });
  if (!free_.empty()) {
    std::unique_ptr<PriorSimulator> sim = std::move(free_.back());
    free_.pop_back();
    return Lease(this, std::move(sim));
  }
  ++created_;
  lock.unlock();
  try {
    return Lease(this, std::make_unique<PriorSimulator>(spec_, options_));
  } catch (...) {
    lock.lock();
    --created_;
    lock.unlock();
    available_.notify_one();
    throw;
  }
}

int SimulatorPool::created() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return created_;
}

void SimulatorPool::give_back(std::unique_ptr<PriorSimulator> sim) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    free_.push_back(std::move(sim));
  }
  available_.notify_one();
}

// ---- HexapodPrior ----

bool StateGuardOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why != nullptr) *why = m;
    return false;
  };
  if (policy != StateGuardPolicy::kStop && policy != StateGuardPolicy::kClamp)
    return fail("StateGuardOptions.policy must be kStop or kClamp");
  if (!(std::isfinite(min_height) && std::isfinite(max_height) && min_height < max_height)) {
    std::ostringstream s;
    s << "StateGuardOptions: need finite min_height < max_height, got " << min_height << ", "
      << max_height;
    return fail(s.str());
  }
  const StateBounds& b = bounds;
  for (double v : {b.joint_angle_margin, b.max_joint_velocity, b.max_position,
                   b.max_linear_velocity, b.max_angular_velocity, b.max_roll_pitch}) {
    if (!(std::isfinite(v) && v >= 0.0)) return fail("StateGuardOptions.bounds must be >= 0");
  }
  return true;
}

bool HexapodPriorOptions::IsValid(std::string* why) const {
  if (!simulator.IsValid(why)) return false;
  if (!guard.IsValid(why)) return false;
  if (pool_capacity < 0) {
    if (why != nullptr) {
      *why = "HexapodPriorOptions.pool_capacity must be >= 0, got " + std::to_string(pool_capacity);
    }
    return false;
  }
  return true;
}

HexapodPrior::HexapodPrior(const HexapodPriorOptions& options) : options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument(why);
}

std::vector<std::string> HexapodPrior::parameter_names() const { return {"removed_leg"}; }

void HexapodPrior::check_phi(const VectorXd& phi) const {
  check_size("HexapodPrior phi", 1, phi.size());
  const double v = phi[0];
  if (!(std::isfinite(v) && v == std::round(v) && v >= -1.0 && v <= kNumLegs - 1)) {
    std::ostringstream s;
    s << "HexapodPrior: removed_leg must be one of -1 (intact), 0, 1, 2, 3, 4, 5, got " << v;
    throw InvalidArgument(s.str());
  }
}

SimulatorPool& HexapodPrior::pool(int removed_leg) const {
  if (removed_leg < -1 || removed_leg >= kNumLegs) {
    throw InvalidArgument("HexapodPrior::pool: removed_leg must be in -1..5, got " +
                          std::to_string(removed_leg));
  }
  std::lock_guard<std::mutex> lock(pools_mutex_);
  std::unique_ptr<SimulatorPool>& p = pools_[removed_leg + 1];
  if (!p) {
    p = std::make_unique<SimulatorPool>(HexapodSpec::with_leg_removed(removed_leg),
                                        options_.simulator, options_.pool_capacity);
  }
  return *p;
}

void HexapodPrior::evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                            Eigen::Ref<VectorXd> dx) const {
  check_size("HexapodPrior::evaluate x", kStateDim, x.size());
  check_size("HexapodPrior::evaluate u", kNumJoints, u.size());
  check_size("HexapodPrior::evaluate dx", kStateDim, dx.size());
  check_phi(phi);
  evaluations_.fetch_add(1, std::memory_order_relaxed);
  VectorXd repaired;
  const bool ok = guard_state(x, &repaired);
  if (!ok && (options_.guard.policy == StateGuardPolicy::kStop || !x.allFinite())) {
    stopped_.fetch_add(1, std::memory_order_relaxed);
    dx.setConstant(std::numeric_limits<double>::quiet_NaN());
    return;
  }
  if (!ok) clamped_.fetch_add(1, std::memory_order_relaxed);
  SimulatorPool::Lease sim = pool(static_cast<int>(phi[0])).acquire();
  sim->set_state(ok ? x : repaired);
  sim->step(u);
  sim->state(dx);
  dx -= x;
}

bool HexapodPrior::guard_state(const VectorXd& x, VectorXd* repaired, std::string* why) const {
  check_size("HexapodPrior::guard_state x", kStateDim, x.size());
  const StateGuardOptions& g = options_.guard;
  static const HexapodSpec kIntact = HexapodSpec::intact();  // joint limits do not depend on phi
  bool ok = check_state(x, kIntact, why, g.bounds);
  const double z = x[kBodyPos + 2];
  if (ok && !(z >= g.min_height && z <= g.max_height)) {
    ok = false;
    if (why != nullptr) {
      std::ostringstream s;
      s << "hexapod state: body height x[38] = " << z << " is outside [" << g.min_height << ", "
        << g.max_height << "]";
      *why = s.str();
    }
  }
  if (!ok && repaired != nullptr) {
    VectorXd& r = *repaired;
    r = x;
    auto clip = [&](int i, double lo, double hi) { r[i] = std::clamp(r[i], lo, hi); };
    for (int j = 0; j < kNumJoints; ++j) {
      const double lim = kIntact.joint_limit(j % kJointsPerLeg);
      clip(kJointPos + j, -lim, lim);
      clip(kJointVel + j, -g.bounds.max_joint_velocity, g.bounds.max_joint_velocity);
    }
    for (int i = 0; i < 3; ++i) {
      clip(kBodyPos + i, -g.bounds.max_position, g.bounds.max_position);
      if (i < 2) clip(kBodyRpy + i, -g.bounds.max_roll_pitch, g.bounds.max_roll_pitch);
      clip(kBodyLinVel + i, -g.bounds.max_linear_velocity, g.bounds.max_linear_velocity);
      clip(kBodyAngVel + i, -g.bounds.max_angular_velocity, g.bounds.max_angular_velocity);
    }
    clip(kBodyPos + 2, g.min_height, g.max_height);
  }
  return ok;
}

StateGuardCounts HexapodPrior::guard_counts() const {
  StateGuardCounts c;
  c.evaluations = evaluations_.load(std::memory_order_relaxed);
  c.stopped = stopped_.load(std::memory_order_relaxed);
  c.clamped = clamped_.load(std::memory_order_relaxed);
  return c;
}

void HexapodPrior::reset_guard_counts() {
  evaluations_.store(0, std::memory_order_relaxed);
  stopped_.store(0, std::memory_order_relaxed);
  clamped_.store(0, std::memory_order_relaxed);
}

std::unique_ptr<model::MeanFunction> HexapodPrior::clone() const {
  return std::make_unique<HexapodPrior>(options_);
}

model::PriorParameters HexapodPrior::prior_parameters() {
  model::PriorParameters p;
  p.names = {"removed_leg"};
  p.values = VectorXd::Constant(1, -1.0);
  p.tunable = {0};
  p.lower = VectorXd::Constant(1, -1.0);
  p.upper = VectorXd::Constant(1, kNumLegs - 1);
  p.choices = {{-1.0, 0.0, 1.0, 2.0, 3.0, 4.0, 5.0}};
  return p;
}

}  // namespace drops::hexapod

// The description-file engine study (docs/decisions/description-file-engine.md): MuJoCo 2.2 and
// DART 6.12's URDF loader side by side, on the DFKI double pendulum (against the analytic model of
// tests/double_pendulum.hpp) and on a 6-joint arm (tests/data/arm6.urdf; the two engines against
// each other). Measures, single-threaded: the time per forward-dynamics evaluation and per control
// step (0.01 s as ten 1 ms substeps of RK4 through each engine's forward dynamics, and of each
// engine's own semi-implicit Euler step) over a batch of random states; the agreement with the
// analytic model (accelerations, 2 s trajectories) with the file's parameters and with every kind
// of phi changed; loading the file, copying a model, making per-thread data; two threads.
// Prints markdown tables. Usage: description_engines [--batch N] [--repeats R]
//
// Coulomb friction is applied by drops as a smooth torque -f_c tanh(qd / v_s) (the analytic
// model's), not by the engines: MuJoCo's frictionloss is a constraint of its solver and DART's
// Coulomb friction acts only in its World's constraint solver; both are measured separately.
#include <mujoco/mujoco.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <dart/dart.hpp>
#include <dart/utils/urdf/DartLoader.hpp>
#include <fstream>
#include <functional>
#include <memory>
#include <numbers>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "double_pendulum.hpp"
#include "drops/core/rng.hpp"

namespace {

using drops::MatrixXd;
using drops::VectorXd;
using drops::fixtures::DoublePendulumParams;
using Clock = std::chrono::steady_clock;

constexpr double kPi = std::numbers::pi;
constexpr double kSubstep = 1e-3;  // s
constexpr int kSubsteps = 10;      // per control step of 0.01 s

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The DFKI file's joint base_weld names a parent link "world" that it does not declare, which
// urdfdom and MuJoCo refuse: declare it.
std::string declare_world(std::string urdf) {
  if (urdf.find("\"world\"") != std::string::npos &&
      !std::regex_search(urdf, std::regex("<link\\s+name\\s*=\\s*\"world\""))) {
    const auto robot = urdf.find("<robot");
    const auto end = urdf.find('>', robot);
    urdf.insert(end + 1, "\n  <link name=\"world\"/>");
  }
  return urdf;
}

// DART's loader returns no skeleton when a visual's mesh is missing: drop the visuals.
std::string strip_visuals(const std::string& urdf) {
  return std::regex_replace(urdf, std::regex("<visual>[\\s\\S]*?</visual>"), "");
}

// ---------------------------------------------------------------------------------------------
// The engines behind one small interface: state and joint torques of the joints in `names` order.

struct EngineModel {
  std::vector<std::string> joints;
  std::vector<double> damping, coulomb;  // per joint, from the file
};

class Mujoco {
 public:
  explicit Mujoco(const std::string& urdf) {
    auto vfs = std::make_unique<mjVFS>();
    mj_defaultVFS(vfs.get());
    if (mj_makeEmptyFileVFS(vfs.get(), "model.urdf", static_cast<int>(urdf.size())) != 0)
      throw std::runtime_error("mj_makeEmptyFileVFS failed");
    std::memcpy(vfs->filedata[vfs->nfile - 1], urdf.data(), urdf.size());
    char error[1000] = "";
    model_ = mj_loadXML("model.urdf", vfs.get(), error, sizeof error);
    mj_deleteVFS(vfs.get());
    if (!model_) throw std::runtime_error(std::string("MuJoCo: ") + error);
    for (int j = 0; j < model_->njnt; ++j) {
      info_.joints.push_back(mj_id2name(model_, mjOBJ_JOINT, j));
      info_.damping.push_back(model_->dof_damping[model_->jnt_dofadr[j]]);
      info_.coulomb.push_back(model_->dof_frictionloss[model_->jnt_dofadr[j]]);
      model_->jnt_limited[j] = 0;                           // the analytic model has no limits
      model_->dof_frictionloss[model_->jnt_dofadr[j]] = 0;  // applied by drops, smooth
    }
    model_->opt.disableflags |= mjDSBL_CONTACT;  // a prior of a fixed-base arm: no self-contact
    model_->opt.timestep = kSubstep;
    model_->opt.integrator = mjINT_EULER;
    data_ = mj_makeData(model_);
  }
  Mujoco(const Mujoco& other) : info_(other.info_) {
    model_ = mj_copyModel(nullptr, other.model_);
    data_ = mj_makeData(model_);
  }
  ~Mujoco() {
    mj_deleteData(data_);
    mj_deleteModel(model_);
  }
  int nv() const { return model_->nv; }
  const EngineModel& info() const { return info_; }
  mjModel* model() { return model_; }
  // qdd = forward dynamics at (q, qd) under generalized force `force` (dof_damping included).
  void forward(const double* q, const double* qd, const double* force, double* qdd) {
    std::copy_n(q, model_->nq, data_->qpos);
    std::copy_n(qd, model_->nv, data_->qvel);
    std::copy_n(force, model_->nv, data_->qfrc_applied);
    mj_forward(model_, data_);
    std::copy_n(data_->qacc, model_->nv, qdd);
  }
  // One native step of opt.timestep from the state in data (semi-implicit Euler by default).
  void set_state(const double* q, const double* qd) {
    std::copy_n(q, model_->nq, data_->qpos);
    std::copy_n(qd, model_->nv, data_->qvel);
  }
  void step(const double* force) {
    std::copy_n(force, model_->nv, data_->qfrc_applied);
    mj_step(model_, data_);
  }
  void get_state(double* q, double* qd) const {
    std::copy_n(data_->qpos, model_->nq, q);
    std::copy_n(data_->qvel, model_->nv, qd);
  }
  mjData* data() { return data_; }

 private:
  mjModel* model_ = nullptr;
  mjData* data_ = nullptr;
  EngineModel info_;
};

class Dart {
 public:
  explicit Dart(const std::string& urdf) {
    dart::utils::DartLoader loader;
    skel_ = loader.parseSkeletonString(strip_visuals(urdf), dart::common::Uri("file:///"));
    if (!skel_) throw std::runtime_error("DART: the URDF did not load");
    for (std::size_t i = 0; i < skel_->getNumDofs(); ++i) {
      auto* dof = skel_->getDof(i);
      info_.joints.push_back(dof->getJoint()->getName());
      info_.damping.push_back(dof->getDampingCoefficient());
      info_.coulomb.push_back(dof->getCoulombFriction());
    }
    skel_->setTimeStep(kSubstep);
    damping_ = Eigen::Map<const Eigen::VectorXd>(info_.damping.data(), info_.damping.size());
    armature_ = Eigen::VectorXd::Zero(skel_->getNumDofs());
    set_damping_in_joints(false);
  }
  Dart(const Dart& other)
      : skel_(other.skel_->cloneSkeleton()),
        info_(other.info_),
        damping_(other.damping_),
        armature_(other.armature_),
        damping_in_joints_(other.damping_in_joints_) {}
  int nv() const { return static_cast<int>(skel_->getNumDofs()); }
  const EngineModel& info() const { return info_; }
  dart::dynamics::Skeleton& skeleton() { return *skel_; }
  // DART's articulated-body forward dynamics treats joint damping implicitly, with the
  // skeleton's time step (B h added to the articulated inertia): with `in_joints` false the
  // damping is applied as the explicit force -B qd instead, as in the analytic model.
  void set_damping_in_joints(bool in_joints) {
    damping_in_joints_ = in_joints;
    for (std::size_t i = 0; i < skel_->getNumDofs(); ++i)
      skel_->getDof(i)->setDampingCoefficient(in_joints ? damping_[i] : 0.0);
  }
  void set_damping(const Eigen::VectorXd& b) {
    damping_ = b;
    set_damping_in_joints(damping_in_joints_);
  }
  // Rotor inertia: DART 6 has none; forward_mass_matrix() adds it to M's diagonal.
  void set_armature(const Eigen::VectorXd& a) { armature_ = a; }
  // Articulated-body algorithm (computeForwardDynamics).
  void forward(const double* q, const double* qd, const double* force, double* qdd) {
    const int n = nv();
    const Eigen::Map<const Eigen::VectorXd> v(qd, n);
    skel_->setPositions(Eigen::Map<const Eigen::VectorXd>(q, n));
    skel_->setVelocities(v);
    Eigen::VectorXd f = Eigen::Map<const Eigen::VectorXd>(force, n);
    if (!damping_in_joints_) f -= damping_.cwiseProduct(v);
    skel_->setForces(f);
    skel_->computeForwardDynamics();
    Eigen::Map<Eigen::VectorXd>(qdd, n) = skel_->getAccelerations();
  }
  // (M + diag(armature)) qdd = force - B qd - C(q, qd) - g(q), with DART's M and C + g.
  void forward_mass_matrix(const double* q, const double* qd, const double* force, double* qdd) {
    const int n = nv();
    const Eigen::Map<const Eigen::VectorXd> v(qd, n);
    skel_->setPositions(Eigen::Map<const Eigen::VectorXd>(q, n));
    skel_->setVelocities(v);
    Eigen::MatrixXd m = skel_->getMassMatrix();
    m.diagonal() += armature_;
    const Eigen::VectorXd rhs = Eigen::Map<const Eigen::VectorXd>(force, n) -
                                damping_.cwiseProduct(v) - skel_->getCoriolisAndGravityForces();
    Eigen::Map<Eigen::VectorXd>(qdd, n) = m.llt().solve(rhs);
  }
  void set_state(const double* q, const double* qd) {
    skel_->setPositions(Eigen::Map<const Eigen::VectorXd>(q, nv()));
    skel_->setVelocities(Eigen::Map<const Eigen::VectorXd>(qd, nv()));
  }
  // One semi-implicit Euler step of the skeleton alone (what World::step does without
  // constraints): qd += h qdd, then q += h qd.
  void step(const double* force) {
    Eigen::VectorXd f = Eigen::Map<const Eigen::VectorXd>(force, nv());
    if (!damping_in_joints_) f -= damping_.cwiseProduct(skel_->getVelocities());
    skel_->setForces(f);
    skel_->computeForwardDynamics();
    skel_->integrateVelocities(kSubstep);
    skel_->integratePositions(kSubstep);
  }
  void get_state(double* q, double* qd) const {
    Eigen::Map<Eigen::VectorXd>(q, nv()) = skel_->getPositions();
    Eigen::Map<Eigen::VectorXd>(qd, nv()) = skel_->getVelocities();
  }

 private:
  dart::dynamics::SkeletonPtr skel_;
  EngineModel info_;
  Eigen::VectorXd damping_, armature_;
  bool damping_in_joints_ = false;
};

// ---------------------------------------------------------------------------------------------
// Batches, timing, trajectories.

struct Batch {
  MatrixXd q, qd, tau;  // (B, n) each
};

Batch random_batch(int b, int n, double max_angle, double max_speed,
                   const std::vector<double>& max_torque, std::uint64_t seed) {
  drops::Rng rng(seed);
  Batch s{MatrixXd(b, n), MatrixXd(b, n), MatrixXd(b, n)};
  for (int i = 0; i < b; ++i)
    for (int j = 0; j < n; ++j) {
      s.q(i, j) = rng.uniform(-max_angle, max_angle);
      s.qd(i, j) = rng.uniform(-max_speed, max_speed);
      s.tau(i, j) = rng.uniform(-max_torque[j], max_torque[j]);
    }
  return s;
}

// The smooth Coulomb friction drops applies: -f_c tanh(qd / v_s).
constexpr double kCoulombVelocity = 0.01;  // rad/s, the analytic model's default
void add_coulomb(const std::vector<double>& fc, const double* qd, double* force, int n) {
  for (int j = 0; j < n; ++j) force[j] -= fc[j] * std::tanh(qd[j] / kCoulombVelocity);
}

using Forward = std::function<void(const double*, const double*, const double*, double*)>;

// RK4 over `steps` substeps of kSubstep from (q, qd) with torque tau held, through `forward`, the
// smooth Coulomb friction fc added to the force at every stage.
void rk4(const Forward& forward, const std::vector<double>& fc, int n, int steps, double* q,
         double* qd, const double* tau) {
  std::vector<double> k[4], kv[4], qs(n), vs(n), f(n);
  for (auto& v : k) v.resize(n);
  for (auto& v : kv) v.resize(n);
  auto stage = [&](const double* qq, const double* vv, std::vector<double>& dq,
                   std::vector<double>& dv) {
    std::copy_n(tau, n, f.data());
    add_coulomb(fc, vv, f.data(), n);
    forward(qq, vv, f.data(), dv.data());
    std::copy_n(vv, n, dq.data());
  };
  const double h = kSubstep;
  for (int s = 0; s < steps; ++s) {
    stage(q, qd, k[0], kv[0]);
    for (int c = 1; c < 4; ++c) {
      const double a = c == 3 ? h : 0.5 * h;
      for (int j = 0; j < n; ++j) {
        qs[j] = q[j] + a * k[c - 1][j];
        vs[j] = qd[j] + a * kv[c - 1][j];
      }
      stage(qs.data(), vs.data(), k[c], kv[c]);
    }
    for (int j = 0; j < n; ++j) {
      q[j] += h / 6 * (k[0][j] + 2 * k[1][j] + 2 * k[2][j] + k[3][j]);
      qd[j] += h / 6 * (kv[0][j] + 2 * kv[1][j] + 2 * kv[2][j] + kv[3][j]);
    }
  }
}

// The least over `repeats` of the CPU seconds of this thread one call of `f` takes, divided by
// `per`: other processes on the machine then add no time (the least: caches and frequency only
// ever make a repeat slower). `wall`: wall-clock seconds instead (for work on several threads).
double time_per(const std::function<void()>& f, int repeats, double per, bool wall = false) {
  auto now = [wall] {
    if (wall) return std::chrono::duration<double>(Clock::now().time_since_epoch()).count();
    timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
  };
  std::vector<double> t;
  f();  // warm-up
  for (int r = 0; r < repeats; ++r) {
    const double start = now();
    f();
    t.push_back((now() - start) / per);
  }
  return *std::min_element(t.begin(), t.end());
}

// Accelerations of a batch through `forward` (the Coulomb friction added to the torques).
MatrixXd batch_forward(const Forward& forward, const std::vector<double>& fc, const Batch& s) {
  const int n = static_cast<int>(s.q.cols());
  MatrixXd qdd(s.q.rows(), n);
  std::vector<double> q(n), qd(n), f(n), a(n);
  for (Eigen::Index i = 0; i < s.q.rows(); ++i) {
    for (int j = 0; j < n; ++j) {
      q[j] = s.q(i, j);
      qd[j] = s.qd(i, j);
      f[j] = s.tau(i, j);
    }
    add_coulomb(fc, qd.data(), f.data(), n);
    forward(q.data(), qd.data(), f.data(), a.data());
    for (int j = 0; j < n; ++j) qdd(i, j) = a[j];
  }
  return qdd;
}

// One control step (kSubsteps of RK4) for every state of the batch; returns the states after it
// as [q, qd] rows.
MatrixXd batch_rk4_step(const Forward& forward, const std::vector<double>& fc, const Batch& s,
                        int substeps = kSubsteps) {
  const int n = static_cast<int>(s.q.cols());
  MatrixXd out(s.q.rows(), 2 * n);
  std::vector<double> q(n), qd(n), tau(n);
  for (Eigen::Index i = 0; i < s.q.rows(); ++i) {
    for (int j = 0; j < n; ++j) {
      q[j] = s.q(i, j);
      qd[j] = s.qd(i, j);
      tau[j] = s.tau(i, j);
    }
    rk4(forward, fc, n, substeps, q.data(), qd.data(), tau.data());
    for (int j = 0; j < n; ++j) {
      out(i, j) = q[j];
      out(i, n + j) = qd[j];
    }
  }
  return out;
}

// One control step of an engine's own semi-implicit Euler (kSubsteps of 1 ms) for every state.
template <class Engine>
MatrixXd batch_native_step(Engine& e, const std::vector<double>& fc, const Batch& s,
                           int substeps = kSubsteps) {
  const int n = static_cast<int>(s.q.cols());
  MatrixXd out(s.q.rows(), 2 * n);
  std::vector<double> q(n), qd(n), f(n);
  for (Eigen::Index i = 0; i < s.q.rows(); ++i) {
    for (int j = 0; j < n; ++j) {
      q[j] = s.q(i, j);
      qd[j] = s.qd(i, j);
    }
    e.set_state(q.data(), qd.data());
    for (int k = 0; k < substeps; ++k) {
      for (int j = 0; j < n; ++j) f[j] = s.tau(i, j);
      add_coulomb(fc, qd.data(), f.data(), n);
      e.step(f.data());
      e.get_state(q.data(), qd.data());
    }
    for (int j = 0; j < n; ++j) {
      out(i, j) = q[j];
      out(i, n + j) = qd[j];
    }
  }
  return out;
}

// The analytic double pendulum as a Forward (parameters p, friction added by the caller: p's own
// Coulomb friction must be 0 and its damping is p's).
Forward analytic_forward(const DoublePendulumParams& p) {
  return [p](const double* q, const double* qd, const double* force, double* qdd) {
    DoublePendulumParams r = p;
    r.coulomb = {0, 0};
    r.torque_scale = {1, 1};
    const Eigen::Vector4d x(q[0], q[1], qd[0], qd[1]);
    const Eigen::Vector2d a = drops::fixtures::joint_accelerations(r, x, {force[0], force[1]});
    qdd[0] = a[0];
    qdd[1] = a[1];
  };
}

double max_abs(const MatrixXd& m) { return m.cwiseAbs().maxCoeff(); }

// ---------------------------------------------------------------------------------------------
// phi written into each engine: the double pendulum's bodies Link1, Link2 and joints Joint1, 2.

// The URDF's frame of link i is turned about the joint axis (x) by rpy_x[i] from the analytic
// model's frame ("along" = -z, "across" = +y at q = 0): Link2's by -3.1416.
constexpr double kRpyX[2] = {0.0, -3.1416};

Eigen::Vector3d com_in_link_frame(const DoublePendulumParams& p, int i) {
  const Eigen::Vector3d in_model(0.0, p.com_across[i], -p.com_along[i]);
  return Eigen::AngleAxisd(-kRpyX[i], Eigen::Vector3d::UnitX()) * in_model;
}

void write_phi(Mujoco& e, const DoublePendulumParams& p) {
  mjModel* m = e.model();
  const char* bodies[2] = {"Link1", "Link2"};
  const char* joints[2] = {"Joint1", "Joint2"};
  for (int i = 0; i < 2; ++i) {
    const int b = mj_name2id(m, mjOBJ_BODY, bodies[i]);
    const int d = m->jnt_dofadr[mj_name2id(m, mjOBJ_JOINT, joints[i])];
    m->body_mass[b] = p.mass[i];
    const Eigen::Vector3d c = com_in_link_frame(p, i);
    for (int k = 0; k < 3; ++k) m->body_ipos[3 * b + k] = c[k];
    // Principal inertia (the file's is diagonal, body_iquat the identity): only ixx acts here.
    for (int k = 0; k < 3; ++k) m->body_inertia[3 * b + k] = p.inertia[i];
    m->dof_damping[d] = p.damping[i];
    m->dof_armature[d] = p.armature[i];
  }
  m->opt.gravity[2] = -p.gravity;
}

void write_phi(Dart& e, const DoublePendulumParams& p) {
  auto& s = e.skeleton();
  const char* bodies[2] = {"Link1", "Link2"};
  for (int i = 0; i < 2; ++i) {
    auto* b = s.getBodyNode(bodies[i]);
    b->setMass(p.mass[i]);
    b->setLocalCOM(com_in_link_frame(p, i));
    b->setMomentOfInertia(p.inertia[i], p.inertia[i], p.inertia[i]);
  }
  e.set_damping(Eigen::Vector2d(p.damping[0], p.damping[1]));
  e.set_armature(Eigen::Vector2d(p.armature[0], p.armature[1]));
  s.setGravity(Eigen::Vector3d(0, 0, -p.gravity));
}

// The double pendulum with every kind of phi away from the file's values.
DoublePendulumParams changed_phi() {
  DoublePendulumParams p = drops::fixtures::dfki_urdf_double_pendulum();
  p.mass = {0.75, 0.5};
  p.com_along = {0.25, 0.18};
  p.com_across = {0.01, -0.006};
  p.inertia = {0.012, 0.005};
  p.damping = {0.05, 0.02};
  p.coulomb = {0.06, 0.1};
  p.armature = {6.07e-5 * 36, 6.07e-5 * 36};  // the lab's rotor inertia through gear ratio 6
  p.gravity = 9.5;
  return p;
}

std::vector<double> coulomb_of(const DoublePendulumParams& p) {
  return {p.coulomb[0], p.coulomb[1]};
}

void check_joint_order(const EngineModel& a, const EngineModel& b) {
  if (a.joints != b.joints) throw std::runtime_error("the engines order the joints differently");
}

// ---------------------------------------------------------------------------------------------

struct Options {
  int batch = 1000;
  int repeats = 5;
};

void double_pendulum(const Options& o, const std::string& urdf) {
  std::printf("## DFKI double pendulum (tests/data/double-pendulum-dfki/double_pendulum.urdf)\n\n");
  Mujoco mj(urdf);
  Dart dt(urdf);
  check_joint_order(mj.info(), dt.info());
  const auto file = drops::fixtures::dfki_urdf_double_pendulum();
  // The file's values as the engines read them.
  std::printf("joints (MuJoCo, DART): ");
  for (std::size_t j = 0; j < 2; ++j)
    std::printf("%s damping %g/%g friction %g/%g; ", mj.info().joints[j].c_str(),
                mj.info().damping[j], dt.info().damping[j], mj.info().coulomb[j],
                dt.info().coulomb[j]);
  std::printf("\nLink2's centre of mass from the analytic parameters: %s (file: 0 0 0.16635)\n\n",
              [&] {
                std::ostringstream s;
                s << com_in_link_frame(file, 1).transpose();
                return s.str();
              }()
                  .c_str());

  const Batch s = random_batch(o.batch, 2, kPi, 5.0, {2.0, 2.0}, 1);
  const Forward mj_fwd = [&](auto q, auto v, auto f, auto a) { mj.forward(q, v, f, a); };
  const Forward dt_aba = [&](auto q, auto v, auto f, auto a) { dt.forward(q, v, f, a); };
  const Forward dt_mm = [&](auto q, auto v, auto f, auto a) { dt.forward_mass_matrix(q, v, f, a); };

  // (2) Accelerations, the file's phi and every phi changed.
  std::printf(
      "### Accelerations at %d random states (q in [-pi, pi], qd in [-5, 5] rad/s, "
      "tau in [-2, 2] N m): max |qdd - analytic| (rad/s^2)\n\n",
      o.batch);
  std::printf(
      "| phi | analytic max |qdd| | MuJoCo mj_forward | DART ABA, damping explicit | "
      "DART ABA, damping in the joints (implicit, h = 1 ms) | DART M + armature, solve |\n");
  std::printf("|---|---:|---:|---:|---:|---:|\n");
  for (const auto& [label, p] : {std::pair<const char*, DoublePendulumParams>{"file", file},
                                 {"all changed", changed_phi()}}) {
    write_phi(mj, p);
    write_phi(dt, p);
    const auto fc = coulomb_of(p);
    const MatrixXd ref = batch_forward(analytic_forward(p), fc, s);
    const MatrixXd a_mj = batch_forward(mj_fwd, fc, s);
    const MatrixXd a_aba = batch_forward(dt_aba, fc, s);
    dt.set_damping_in_joints(true);
    const MatrixXd a_implicit = batch_forward(dt_aba, fc, s);
    dt.set_damping_in_joints(false);
    const MatrixXd a_mm = batch_forward(dt_mm, fc, s);
    const bool armature = p.armature[0] != 0;
    std::printf("| %s%s | %.3g | %.2e | %.2e%s | %.2e | %.2e |\n", label,
                armature ? " (with armature)" : "", max_abs(ref), max_abs(a_mj - ref),
                max_abs(a_aba - ref), armature ? " (no armature in DART)" : "",
                max_abs(a_implicit - ref), max_abs(a_mm - ref));
  }

  // (2) 2 s trajectories, RK4 at 1 ms through each engine against the analytic model's RK4 at
  // 1 ms, from 20 random states with constant random torques. The motion is chaotic (differences
  // grow by orders of magnitude in 2 s): agreement to round-off means the same dynamics.
  const Batch starts = random_batch(20, 2, kPi, 3.0, {1.0, 1.0}, 2);
  auto advance = [](Batch& b, const MatrixXd& x) {
    b.q = x.leftCols(b.q.cols());
    b.qd = x.rightCols(b.q.cols());
  };
  std::printf(
      "\n### 2 s trajectories, RK4 at 1 ms, from 20 random states (qd in [-3, 3] rad/s, "
      "constant tau in [-1, 1] N m): max |q - analytic| (rad) over the trajectory\n\n");
  std::printf("| phi | MuJoCo (mj_forward) | DART (M + armature, solve) |\n|---|---:|---:|\n");
  for (const auto& [label, p] : {std::pair<const char*, DoublePendulumParams>{"file", file},
                                 {"all changed", changed_phi()}}) {
    write_phi(mj, p);
    write_phi(dt, p);
    const auto fc = coulomb_of(p);
    double e_mj = 0, e_dt = 0;
    Batch ref = starts, cur_mj = starts, cur_dt = starts;
    for (int step = 0; step < 200; ++step) {
      advance(ref, batch_rk4_step(analytic_forward(p), fc, ref));
      advance(cur_mj, batch_rk4_step(mj_fwd, fc, cur_mj));
      advance(cur_dt, batch_rk4_step(dt_mm, fc, cur_dt));
      e_mj = std::max(e_mj, max_abs(cur_mj.q - ref.q));
      e_dt = std::max(e_dt, max_abs(cur_dt.q - ref.q));
    }
    std::printf("| %s | %.2e | %.2e |\n", label, e_mj, e_dt);
  }

  // The engines' own step, semi-implicit Euler at 1 ms (MuJoCo's integrates the joint damping
  // implicitly; DART's skeleton step here has it explicit): one control step of 0.01 s from the
  // batch against the analytic RK4 at 1 ms, with the analytic model's own semi-implicit Euler.
  std::printf(
      "\n### One control step (0.01 s) of semi-implicit Euler at 1 ms from the %d states: "
      "max |q - analytic RK4| (rad) / max |qd - analytic RK4| (rad/s)\n\n",
      o.batch);
  std::printf(
      "| phi | MuJoCo mj_step | DART skeleton step | analytic semi-implicit Euler |\n"
      "|---|---:|---:|---:|\n");
  for (const auto& [label, p] : {std::pair<const char*, DoublePendulumParams>{"file", file},
                                 {"all changed", changed_phi()}}) {
    write_phi(mj, p);
    write_phi(dt, p);
    const auto fc = coulomb_of(p);
    const Forward ana = analytic_forward(p);
    const MatrixXd ref = batch_rk4_step(ana, fc, s);
    MatrixXd euler(s.q.rows(), 4);
    for (Eigen::Index i = 0; i < s.q.rows(); ++i) {
      double q[2] = {s.q(i, 0), s.q(i, 1)}, v[2] = {s.qd(i, 0), s.qd(i, 1)}, f[2], a[2];
      for (int k = 0; k < kSubsteps; ++k) {
        f[0] = s.tau(i, 0);
        f[1] = s.tau(i, 1);
        add_coulomb(fc, v, f, 2);
        ana(q, v, f, a);
        for (int j = 0; j < 2; ++j) {
          v[j] += kSubstep * a[j];
          q[j] += kSubstep * v[j];
        }
      }
      euler.row(i) << q[0], q[1], v[0], v[1];
    }
    auto err = [&](const MatrixXd& x) {
      return std::pair{max_abs(x.leftCols(2) - ref.leftCols(2)),
                       max_abs(x.rightCols(2) - ref.rightCols(2))};
    };
    const auto [mq, mv] = err(batch_native_step(mj, fc, s));
    const auto [dq, dv] = err(batch_native_step(dt, fc, s));
    const auto [aq, av] = err(euler);
    std::printf("| %s | %.2e / %.2e | %.2e / %.2e%s | %.2e / %.2e |\n", label, mq, mv, dq, dv,
                p.armature[0] != 0 ? " (no armature)" : "", aq, av);
  }

  // The engines' own Coulomb friction against the smooth one, each engine with its own step:
  // MuJoCo's frictionloss (a constraint of its solver) against the smooth friction applied, both
  // with mj_step; DART's joint Coulomb friction (World::step's constraint solver) against the
  // smooth friction applied, both with World::step. 2 s from 20 small swings, no torque.
  {
    const Batch swings = random_batch(20, 2, 0.5, 1.0, {0.0, 0.0}, 4);
    const auto fc = coulomb_of(file);
    const std::vector<double> none(2, 0.0);
    Mujoco smooth(urdf), native(urdf);  // both load without frictionloss (the constructor)
    write_phi(smooth, file);
    write_phi(native, file);
    for (int j = 0; j < 2; ++j) native.model()->dof_frictionloss[j] = file.coulomb[j];
    Dart dsmooth(urdf), dnative(urdf);
    auto world_of = [&](Dart& d, bool coulomb) {
      write_phi(d, file);
      d.set_damping_in_joints(true);
      for (int j = 0; j < 2; ++j)
        d.skeleton().getDof(j)->setCoulombFriction(coulomb ? file.coulomb[j] : 0.0);
      auto world = dart::simulation::World::create();
      world->setTimeStep(kSubstep);
      world->setGravity(Eigen::Vector3d(0, 0, -file.gravity));
      world->addSkeleton(d.skeleton().getPtr());
      return world;
    };
    auto w_smooth = world_of(dsmooth, false);
    auto w_native = world_of(dnative, true);
    double e_mj = 0, e_dt = 0;
    for (int i = 0; i < 20; ++i) {
      double q1[2] = {swings.q(i, 0), swings.q(i, 1)}, v1[2] = {swings.qd(i, 0), swings.qd(i, 1)};
      double q2[2] = {q1[0], q1[1]}, v2[2] = {v1[0], v1[1]};
      smooth.set_state(q1, v1);
      native.set_state(q2, v2);
      auto& s1 = dsmooth.skeleton();
      auto& s2 = dnative.skeleton();
      s1.setPositions(Eigen::Vector2d(q1[0], q1[1]));
      s1.setVelocities(Eigen::Vector2d(v1[0], v1[1]));
      s2.setPositions(s1.getPositions());
      s2.setVelocities(s1.getVelocities());
      for (int k = 0; k < 2000; ++k) {
        double f[2] = {0, 0};
        smooth.get_state(q1, v1);
        add_coulomb(fc, v1, f, 2);
        smooth.step(f);
        native.step(none.data());
        smooth.get_state(q1, v1);
        native.get_state(q2, v2);
        e_mj = std::max({e_mj, std::abs(q1[0] - q2[0]), std::abs(q1[1] - q2[1])});
        Eigen::Vector2d g(0, 0);
        const Eigen::VectorXd v = s1.getVelocities();
        add_coulomb(fc, v.data(), g.data(), 2);
        s1.setForces(g);
        w_smooth->step();
        s2.setForces(Eigen::Vector2d::Zero());
        w_native->step();
        e_dt = std::max(e_dt, (s1.getPositions() - s2.getPositions()).cwiseAbs().maxCoeff());
      }
    }
    std::printf(
        "\n### The engines' own Coulomb friction against the smooth f_c tanh(qd / %g), "
        "each engine's own step at 1 ms, file's phi: max |q native - q smooth| (rad) over "
        "2 s from 20 small swings (q in [-0.5, 0.5] rad, qd in [-1, 1] rad/s, no torque)"
        "\n\n| MuJoCo frictionloss (constraint) | DART joint Coulomb friction (World "
        "constraint solver) |\n|---:|---:|\n| %.2e | %.2e |\n",
        kCoulombVelocity, e_mj, e_dt);
  }

  // (1) Timings.
  write_phi(mj, file);
  write_phi(dt, file);
  const auto fc = coulomb_of(file);
  std::printf("\n### Time, single thread (CPU time), batch of %d states (best of %d repeats)\n\n",
              o.batch, o.repeats);
  std::printf(
      "| | forward dynamics, us per evaluation | control step (10 x 1 ms RK4 = 40 "
      "evaluations), us per state | control step (10 x 1 ms semi-implicit Euler), us per "
      "state |\n|---|---:|---:|---:|\n");
  auto row = [&](const char* name, const Forward& f, const std::function<void()>& euler) {
    const double t_fwd = time_per([&] { batch_forward(f, fc, s); }, o.repeats, o.batch);
    const double t_rk4 = time_per([&] { batch_rk4_step(f, fc, s); }, o.repeats, o.batch);
    const double t_eu = euler ? time_per(euler, o.repeats, o.batch) : NAN;
    std::printf("| %s | %.3f | %.2f | %.2f |\n", name, 1e6 * t_fwd, 1e6 * t_rk4, 1e6 * t_eu);
  };
  row("analytic (tests/double_pendulum.hpp)", analytic_forward(file), nullptr);
  row("MuJoCo mj_forward / mj_step", mj_fwd, [&] { batch_native_step(mj, fc, s); });
  row("DART computeForwardDynamics (ABA) / skeleton step", dt_aba,
      [&] { batch_native_step(dt, fc, s); });
  row("DART mass matrix + armature + solve", dt_mm, nullptr);
  const auto changed = changed_phi();
  const double t_mj_phi = time_per([&] { write_phi(mj, changed); }, o.repeats, 1);
  const double t_dt_phi = time_per([&] { write_phi(dt, changed); }, o.repeats, 1);
  std::printf(
      "\nWriting every phi (8 kinds, 2 bodies and 2 joints): MuJoCo %.3f us, DART %.3f us\n",
      1e6 * t_mj_phi, 1e6 * t_dt_phi);
}

void arm(const Options& o, const std::string& urdf) {
  std::printf("\n## 6-joint arm (tests/data/arm6.urdf)\n\n");
  Mujoco mj(urdf);
  Dart dt(urdf);
  check_joint_order(mj.info(), dt.info());
  const int n = mj.nv();
  const auto& fc = mj.info().coulomb;
  const Batch s = random_batch(o.batch, n, kPi, 3.0, {20, 20, 10, 3, 3, 1}, 3);
  const Forward mj_fwd = [&](auto q, auto v, auto f, auto a) { mj.forward(q, v, f, a); };
  const Forward dt_aba = [&](auto q, auto v, auto f, auto a) { dt.forward(q, v, f, a); };
  const Forward dt_mm = [&](auto q, auto v, auto f, auto a) { dt.forward_mass_matrix(q, v, f, a); };
  const MatrixXd a_mj = batch_forward(mj_fwd, fc, s);
  const MatrixXd a_aba = batch_forward(dt_aba, fc, s);
  const MatrixXd a_mm = batch_forward(dt_mm, fc, s);
  std::printf(
      "Accelerations at %d random states (q in [-pi, pi], qd in [-3, 3] rad/s, tau up to "
      "20/20/10/3/3/1 N m): max |qdd| = %.3g rad/s^2; max |MuJoCo - DART ABA| = %.2e, "
      "max |MuJoCo - DART M + solve| = %.2e rad/s^2\n",
      o.batch, max_abs(a_mj), max_abs(a_mj - a_aba), max_abs(a_mj - a_mm));
  {
    const MatrixXd x_mj = batch_rk4_step(mj_fwd, fc, s);
    const MatrixXd x_dt = batch_rk4_step(dt_aba, fc, s);
    // 2 s under gravity alone from 20 states (qd in [-1, 1] rad/s), RK4 at 1 ms, with and
    // without the smooth Coulomb friction: on the wrist (rotor-less, 1e-4 kg m^2 about its axis)
    // its slope f_c / v_s makes RK4 at 1 ms unstable near qd = 0 (h f_c / (v_s I) ~ 100 > 2.8),
    // so it chatters there and the two engines' round-off grows.
    const Batch starts = random_batch(20, n, kPi, 1.0, std::vector<double>(n, 0.0), 5);
    const std::vector<double> none(n, 0.0);
    const MatrixXd y_mj = batch_rk4_step(mj_fwd, fc, starts, 2000);
    const MatrixXd y_dt = batch_rk4_step(dt_aba, fc, starts, 2000);
    const MatrixXd z_mj = batch_rk4_step(mj_fwd, none, starts, 2000);
    const MatrixXd z_dt = batch_rk4_step(dt_aba, none, starts, 2000);
    std::printf(
        "One control step (0.01 s, RK4 at 1 ms) from those states: max |q MuJoCo - q DART| "
        "= %.2e rad, max |qd MuJoCo - qd DART| = %.2e rad/s. 2 s under gravity from 20 "
        "states (RK4 at 1 ms): max |q MuJoCo - q DART| = %.2e rad without Coulomb "
        "friction, %.2e rad with it\n\n",
        max_abs(x_mj.leftCols(n) - x_dt.leftCols(n)),
        max_abs(x_mj.rightCols(n) - x_dt.rightCols(n)),
        max_abs(z_mj.leftCols(n) - z_dt.leftCols(n)), max_abs(y_mj.leftCols(n) - y_dt.leftCols(n)));
  }
  std::printf(
      "| | forward dynamics, us per evaluation | control step (10 x 1 ms RK4), us per "
      "state | control step (10 x 1 ms semi-implicit Euler), us per state |\n"
      "|---|---:|---:|---:|\n");
  auto row = [&](const char* name, const Forward& f, const std::function<void()>& euler) {
    const double t_fwd = time_per([&] { batch_forward(f, fc, s); }, o.repeats, o.batch);
    const double t_rk4 = time_per([&] { batch_rk4_step(f, fc, s); }, o.repeats, o.batch);
    const double t_eu = euler ? time_per(euler, o.repeats, o.batch) : NAN;
    std::printf("| %s | %.3f | %.2f | %.2f |\n", name, 1e6 * t_fwd, 1e6 * t_rk4, 1e6 * t_eu);
  };
  row("MuJoCo mj_forward / mj_step", mj_fwd, [&] { batch_native_step(mj, fc, s); });
  row("DART computeForwardDynamics (ABA) / skeleton step", dt_aba,
      [&] { batch_native_step(dt, fc, s); });
  row("DART mass matrix + armature + solve", dt_mm, nullptr);

  // (3) Per-thread copies, loading.
  std::printf(
      "\n### Loading and per-thread copies (6-joint arm)\n\n| | time | size |\n|---|---:|---:|\n");
  const double t_mj_load = time_per([&] { Mujoco m(urdf); }, o.repeats, 1);
  const double t_dt_load = time_per([&] { Dart d(urdf); }, o.repeats, 1);
  const double t_mj_copy =
      time_per([&] { mj_deleteModel(mj_copyModel(nullptr, mj.model())); }, o.repeats, 1);
  const double t_mj_data = time_per([&] { mj_deleteData(mj_makeData(mj.model())); }, o.repeats, 1);
  const double t_dt_clone = time_per([&] { auto c = dt.skeleton().cloneSkeleton(); }, o.repeats, 1);
  std::printf("| MuJoCo: load the URDF (mj_loadXML) | %.2f ms | |\n", 1e3 * t_mj_load);
  std::printf("| MuJoCo: copy the mjModel (mj_copyModel) | %.1f us | %d bytes |\n", 1e6 * t_mj_copy,
              mj_sizeModel(mj.model()));
  std::printf("| MuJoCo: one mjData (mj_makeData) | %.1f us | %.0f bytes |\n", 1e6 * t_mj_data,
              mj.data()->nbuffer + 8.0 * mj.data()->nstack);
  std::printf("| DART: load the URDF (DartLoader) | %.2f ms | |\n", 1e3 * t_dt_load);
  std::printf("| DART: clone the Skeleton (cloneSkeleton) | %.1f us | |\n", 1e6 * t_dt_clone);

  // Two threads, one engine copy each (MuJoCo: the model shared, one mjData each would do while
  // phi is the same; here one Mujoco copy each, as when threads evaluate different phi).
  std::printf(
      "\n### Two threads, RK4 control steps of the batch (one copy per thread; wall clock, "
      "best of the repeats)\n\n"
      "| | 1 thread, us per state | 2 threads, us per state | max abs difference of the "
      "states, 2 threads - 1 |\n|---|---:|---:|---:|\n");
  auto two = [&](auto& engine, auto forward_of) {
    using E = std::decay_t<decltype(engine)>;
    E a(engine), b(engine);
    const int half = o.batch / 2;
    Batch s1{s.q.topRows(half), s.qd.topRows(half), s.tau.topRows(half)};
    Batch s2{s.q.bottomRows(o.batch - half), s.qd.bottomRows(o.batch - half),
             s.tau.bottomRows(o.batch - half)};
    MatrixXd one, x1, x2;
    const double t1 =
        time_per([&] { one = batch_rk4_step(forward_of(a), fc, s); }, o.repeats, o.batch, true);
    const double t2 = time_per(
        [&] {
          std::thread t([&] { x1 = batch_rk4_step(forward_of(a), fc, s1); });
          x2 = batch_rk4_step(forward_of(b), fc, s2);
          t.join();
        },
        o.repeats, o.batch, true);
    MatrixXd both(one.rows(), one.cols());
    both << x1, x2;
    return std::tuple{t1, t2, max_abs(both - one)};
  };
  const auto [m1, m2, md] = two(mj, [](Mujoco& e) -> Forward {
    return [&e](auto q, auto v, auto f, auto a) { e.forward(q, v, f, a); };
  });
  const auto [d1, d2, dd] = two(dt, [](Dart& e) -> Forward {
    return [&e](auto q, auto v, auto f, auto a) { e.forward(q, v, f, a); };
  });
  std::printf("| MuJoCo | %.2f | %.2f | %.1e |\n| DART ABA | %.2f | %.2f | %.1e |\n", 1e6 * m1,
              1e6 * m2, md, 1e6 * d1, 1e6 * d2, dd);
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if ((a == "--batch" || a == "--repeats") && i + 1 < argc) {
      (a == "--batch" ? o.batch : o.repeats) = std::stoi(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: description_engines [--batch N] [--repeats R]\n");
      return 2;
    }
  }
  try {
    std::printf("MuJoCo %s, DART %s\n\n", mj_versionString(), DART_VERSION);
    double_pendulum(
        o, declare_world(read_text(DROPS_TEST_DATA "/double-pendulum-dfki/double_pendulum.urdf")));
    arm(o, declare_world(read_text(DROPS_TEST_DATA "/arm6.urdf")));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "description_engines: %s\n", e.what());
    return 1;
  }
  return 0;
}

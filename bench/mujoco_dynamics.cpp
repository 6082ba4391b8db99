// MuJoCo 2.2 as the engine of a robot-description prior (docs/decisions/description-file-engine.md,
// where it was measured against DART's URDF loader): on the DFKI double pendulum against the
// analytic model of tests/double_pendulum.hpp (accelerations and 2 s trajectories, with the file's
// parameters and with every kind of phi written into the mjModel; one control step of MuJoCo's own
// semi-implicit Euler; its frictionloss against a smooth Coulomb friction), and on a 6-joint arm
// (tests/data/arm6.urdf): the time per forward-dynamics evaluation and per control step (0.01 s as
// ten 1 ms substeps of RK4 through mj_forward, or of mj_step) over a batch of random states,
// single-threaded; loading the file, copying the model, one mjData; two threads.
// Prints markdown tables. Usage: mujoco_dynamics [--batch N] [--repeats R]
//
// Coulomb friction is applied as a smooth torque -f_c tanh(qd / v_s) (the analytic model's), not
// as MuJoCo's frictionloss, a constraint of its solver; the two are compared.
#include <mujoco/mujoco.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
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
#include "drops/description/description_prior.hpp"

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

// ---------------------------------------------------------------------------------------------
// MuJoCo behind a small interface: state and generalized forces in the model's joint order.

struct FileJoints {  // the joints in the model's order, with the file's damping and friction
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
  const FileJoints& info() const { return info_; }
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
  FileJoints info_;
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

// One control step of MuJoCo's own semi-implicit Euler (kSubsteps of 1 ms) for every state.
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
// phi written into the mjModel: the double pendulum's bodies Link1, Link2 and joints Joint1, 2.

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

// drops::description's prior on the same states: one control step (10 x 1 ms RK4 through
// mj_forward, smooth friction, phi written into its workspace once per batch), CPU time per state.
double time_description_prior(const std::string& file, const std::vector<std::string>& phi_names,
                              const Batch& s, int repeats) {
  drops::description::DescriptionPriorOptions po;
  po.file = file;
  po.parameters = phi_names;
  const drops::description::DescriptionPrior prior(po);
  MatrixXd x(s.q.rows(), 2 * s.q.cols()), dx;
  x << s.q, s.qd;
  const drops::VectorXd phi = prior.default_phi();
  return time_per([&] { prior.evaluate_batch(x, s.tau, phi, dx); }, repeats,
                  static_cast<double>(s.q.rows()));
}

// ---------------------------------------------------------------------------------------------

struct Options {
  int batch = 1000;
  int repeats = 5;
};

void double_pendulum(const Options& o, const std::string& urdf) {
  std::printf("## DFKI double pendulum (tests/data/double-pendulum-dfki/double_pendulum.urdf)\n\n");
  Mujoco mj(urdf);
  const auto file = drops::fixtures::dfki_urdf_double_pendulum();
  const Batch s = random_batch(o.batch, 2, kPi, 5.0, {2.0, 2.0}, 1);
  const Forward mj_fwd = [&](auto q, auto v, auto f, auto a) { mj.forward(q, v, f, a); };
  const std::vector<std::pair<const char*, DoublePendulumParams>> cases{
      {"file", file}, {"all changed", changed_phi()}};

  std::printf(
      "### Against the analytic model: accelerations at %d random states (q in [-pi, pi], qd in "
      "[-5, 5] rad/s, tau in [-2, 2] N m), max |qdd - analytic| (rad/s^2); 2 s trajectories, RK4 "
      "at 1 ms, from 20 random states (qd in [-3, 3] rad/s, constant tau in [-1, 1] N m), max |q "
      "- analytic| (rad); one control step (0.01 s) of mj_step at 1 ms from the %d states against "
      "the analytic RK4, max |q - analytic| (rad) / max |qd - analytic| (rad/s)\n\n",
      o.batch, o.batch);
  std::printf(
      "| phi | analytic max |qdd| | accelerations | 2 s RK4 | one mj_step control step |\n"
      "|---|---:|---:|---:|---:|\n");
  const Batch starts = random_batch(20, 2, kPi, 3.0, {1.0, 1.0}, 2);
  for (const auto& [label, p] : cases) {
    write_phi(mj, p);
    const auto fc = coulomb_of(p);
    const Forward ana = analytic_forward(p);
    const MatrixXd ref = batch_forward(ana, fc, s);
    const double e_acc = max_abs(batch_forward(mj_fwd, fc, s) - ref);
    // The motion is chaotic: agreement to round-off over 2 s means the same dynamics.
    double e_traj = 0;
    Batch a = starts, b = starts;
    for (int step = 0; step < 200; ++step) {
      const MatrixXd xa = batch_rk4_step(ana, fc, a), xb = batch_rk4_step(mj_fwd, fc, b);
      a.q = xa.leftCols(2);
      a.qd = xa.rightCols(2);
      b.q = xb.leftCols(2);
      b.qd = xb.rightCols(2);
      e_traj = std::max(e_traj, max_abs(b.q - a.q));
    }
    const MatrixXd x_ref = batch_rk4_step(ana, fc, s), x_mj = batch_native_step(mj, fc, s);
    std::printf("| %s | %.3g | %.2e | %.2e | %.2e / %.2e |\n", label, max_abs(ref), e_acc, e_traj,
                max_abs(x_mj.leftCols(2) - x_ref.leftCols(2)),
                max_abs(x_mj.rightCols(2) - x_ref.rightCols(2)));
  }

  // MuJoCo's frictionloss (a constraint of its solver) against the smooth friction applied, both
  // with mj_step: 2 s from 20 small swings, no torque.
  {
    const Batch swings = random_batch(20, 2, 0.5, 1.0, {0.0, 0.0}, 4);
    const auto fc = coulomb_of(file);
    const std::vector<double> none(2, 0.0);
    Mujoco smooth(urdf), native(urdf);  // both load without frictionloss (the constructor)
    write_phi(smooth, file);
    write_phi(native, file);
    for (int j = 0; j < 2; ++j) native.model()->dof_frictionloss[j] = file.coulomb[j];
    double e = 0;
    for (int i = 0; i < 20; ++i) {
      double q1[2] = {swings.q(i, 0), swings.q(i, 1)}, v1[2] = {swings.qd(i, 0), swings.qd(i, 1)};
      double q2[2] = {q1[0], q1[1]}, v2[2] = {v1[0], v1[1]};
      smooth.set_state(q1, v1);
      native.set_state(q2, v2);
      for (int k = 0; k < 2000; ++k) {
        double f[2] = {0, 0};
        add_coulomb(fc, v1, f, 2);
        smooth.step(f);
        native.step(none.data());
        smooth.get_state(q1, v1);
        native.get_state(q2, v2);
        e = std::max({e, std::abs(q1[0] - q2[0]), std::abs(q1[1] - q2[1])});
      }
    }
    std::printf(
        "\nMuJoCo's frictionloss against the smooth f_c tanh(qd / %g), both with mj_step at 1 ms, "
        "file's phi: max |q frictionloss - q smooth| = %.2e rad over 2 s from 20 small swings (q "
        "in [-0.5, 0.5] rad, qd in [-1, 1] rad/s, no torque)\n",
        kCoulombVelocity, e);
  }

  write_phi(mj, file);
  const auto fc = coulomb_of(file);
  std::printf(
      "\n### Time, single thread (CPU time), batch of %d states (best of %d repeats)\n\n"
      "| | forward dynamics, us per evaluation | control step (10 x 1 ms RK4 = 40 evaluations), "
      "us per state | control step (10 x 1 ms semi-implicit Euler), us per state |\n"
      "|---|---:|---:|---:|\n",
      o.batch, o.repeats);
  auto row = [&](const char* name, const Forward& f, const std::function<void()>& euler) {
    const double t_fwd = time_per([&] { batch_forward(f, fc, s); }, o.repeats, o.batch);
    const double t_rk4 = time_per([&] { batch_rk4_step(f, fc, s); }, o.repeats, o.batch);
    const double t_eu = euler ? time_per(euler, o.repeats, o.batch) : NAN;
    std::printf("| %s | %.3f | %.2f | %.2f |\n", name, 1e6 * t_fwd, 1e6 * t_rk4, 1e6 * t_eu);
  };
  row("analytic (tests/double_pendulum.hpp)", analytic_forward(file), nullptr);
  row("MuJoCo mj_forward / mj_step", mj_fwd, [&] { batch_native_step(mj, fc, s); });
  std::printf(
      "| drops::description::DescriptionPrior::evaluate_batch (17 phi) | | %.2f | |\n",
      1e6 * time_description_prior(
                DROPS_TEST_DATA "/double-pendulum-dfki/double_pendulum.urdf",
                {"Link1.mass", "Link2.mass", "Link1.com.y", "Link1.com.z", "Link2.com.y",
                 "Link2.com.z", "Link1.inertia", "Link2.inertia", "Joint1.damping",
                 "Joint2.damping", "Joint1.friction", "Joint2.friction", "Joint1.armature",
                 "Joint2.armature", "Joint1.gear", "Joint2.gear", "gravity"},
                s, o.repeats));
  const auto changed = changed_phi();
  std::printf("\nWriting every phi (8 kinds, 2 bodies and 2 joints): %.3f us\n",
              1e6 * time_per([&] { write_phi(mj, changed); }, o.repeats, 1));
}

void arm(const Options& o, const std::string& urdf) {
  std::printf("\n## 6-joint arm (tests/data/arm6.urdf)\n\n");
  Mujoco mj(urdf);
  const int n = mj.nv();
  const auto& fc = mj.info().coulomb;
  const Batch s = random_batch(o.batch, n, kPi, 3.0, {20, 20, 10, 3, 3, 1}, 3);
  const Forward mj_fwd = [&](auto q, auto v, auto f, auto a) { mj.forward(q, v, f, a); };
  std::printf(
      "### Time, single thread (CPU time), batch of %d states (q in [-pi, pi], qd in [-3, 3] "
      "rad/s, tau up to 20/20/10/3/3/1 N m; best of %d repeats)\n\n"
      "| | time |\n|---|---:|\n",
      o.batch, o.repeats);
  std::printf("| forward dynamics (mj_forward) | %.3f us per evaluation |\n",
              1e6 * time_per([&] { batch_forward(mj_fwd, fc, s); }, o.repeats, o.batch));
  std::printf("| control step, 10 x 1 ms RK4 | %.2f us per state |\n",
              1e6 * time_per([&] { batch_rk4_step(mj_fwd, fc, s); }, o.repeats, o.batch));
  std::printf("| control step, 10 x 1 ms mj_step (semi-implicit Euler) | %.2f us per state |\n",
              1e6 * time_per([&] { batch_native_step(mj, fc, s); }, o.repeats, o.batch));
  std::printf("| control step, drops::description::DescriptionPrior::evaluate_batch | %.2f us "
              "per state |\n",
              1e6 * time_description_prior(DROPS_TEST_DATA "/arm6.urdf", {"gravity"}, s,
                                           o.repeats));
  std::printf("| load the URDF (mj_loadXML) | %.2f ms |\n",
              1e3 * time_per([&] { Mujoco m(urdf); }, o.repeats, 1));
  std::printf(
      "| copy the mjModel (mj_copyModel, %d bytes) | %.1f us |\n", mj_sizeModel(mj.model()),
      1e6 * time_per([&] { mj_deleteModel(mj_copyModel(nullptr, mj.model())); }, o.repeats, 1));
  std::printf("| one mjData (mj_makeData, %.0f bytes) | %.1f us |\n",
              mj.data()->nbuffer + 8.0 * mj.data()->nstack,
              1e6 * time_per([&] { mj_deleteData(mj_makeData(mj.model())); }, o.repeats, 1));

  // Two threads, one copy each (as when threads evaluate different phi).
  Mujoco a(mj), b(mj);
  const int half = o.batch / 2;
  const Batch s1{s.q.topRows(half), s.qd.topRows(half), s.tau.topRows(half)};
  const Batch s2{s.q.bottomRows(o.batch - half), s.qd.bottomRows(o.batch - half),
                 s.tau.bottomRows(o.batch - half)};
  const Forward fa = [&](auto q, auto v, auto f, auto r) { a.forward(q, v, f, r); };
  const Forward fb = [&](auto q, auto v, auto f, auto r) { b.forward(q, v, f, r); };
  MatrixXd one, x1, x2;
  const double t1 = time_per([&] { one = batch_rk4_step(fa, fc, s); }, o.repeats, o.batch, true);
  const double t2 = time_per(
      [&] {
        std::thread t([&] { x1 = batch_rk4_step(fa, fc, s1); });
        x2 = batch_rk4_step(fb, fc, s2);
        t.join();
      },
      o.repeats, o.batch, true);
  MatrixXd both(one.rows(), one.cols());
  both << x1, x2;
  std::printf(
      "\nRK4 control steps of the batch, wall clock: 1 thread %.2f us per state, 2 threads (one "
      "copy each) %.2f us per state; max abs difference of the states %.1e\n",
      1e6 * t1, 1e6 * t2, max_abs(both - one));
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if ((a == "--batch" || a == "--repeats") && i + 1 < argc) {
      (a == "--batch" ? o.batch : o.repeats) = std::stoi(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: mujoco_dynamics [--batch N] [--repeats R]\n");
      return 2;
    }
  }
  try {
    std::printf("MuJoCo %s\n\n", mj_versionString());
    double_pendulum(
        o, declare_world(read_text(DROPS_TEST_DATA "/double-pendulum-dfki/double_pendulum.urdf")));
    arm(o, declare_world(read_text(DROPS_TEST_DATA "/arm6.urdf")));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mujoco_dynamics: %s\n", e.what());
    return 1;
  }
  return 0;
}

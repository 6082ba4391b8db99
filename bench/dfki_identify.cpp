// The DFKI double pendulum identified (docs/results/double-pendulum.md, issue 68): every model of
// the page on the same validation recordings and the same error metric (experiment::
// prediction_errors, the open-loop replay of `drops identify`):
//   urdf      the lab's URDF as a description-file prior, nothing tuned
//   lab-1.0, lab-2.0, lab-2.1
//             the lab's model (realaigym::joint_accelerations: M(q) qdd + C qd - G + F = tau,
//             F = b qd + cf atan(100 qd), rotor inertia Ir through the gear ratio gr) with its
//             identified parameter files, RK4 over 10 substeps of 1 ms per control period, the
//             torques not clipped (model_2.1's tl2 = 0 makes joint 2 passive: it is for the
//             pendubot, the recordings drive both joints)
//   ls        least squares of the 10 base parameters of the same model on the fit recordings
//             low-passed (identify.lowpass_hz = --ls-lowpass), accelerations from differences of
//             the smoothed velocities, period-averaged torques
//   gp, gp_prior, mi, gp_mi
//             drops' models learned by experiment::identify with the URDF prior and six tunable
//             phi (--phi; default: the inertia scales of both links, the armature (rotor
//             inertia) and Coulomb friction of both joints:
//             configs/identify-double-pendulum-gp_mi.yaml)
// Usage: dfki_identify [--fit 00,01,02,04] [--validate 03,05] [--models LIST] [--inducing 200]
//        [--gp-mi-max-points 0] [--ls-lowpass 5] [--derivative-window 0.02] [--phi LIST]
//        [--threads 2] [--csv FILE] [--phi-csv FILE] [--data DIR]
// Prints a markdown table (median / p90 of |predicted - recorded| per horizon and state, pooled
// over the validation recordings' start points) and writes it as CSV with --csv.
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/description/description_prior.hpp"
#include "drops/experiment/identify.hpp"
#include "drops/realaigym/plant.hpp"

namespace {

using drops::MatrixXd;
using drops::VectorXd;
namespace ex = drops::experiment;

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> v;
  std::stringstream ss(s);
  std::string c;
  while (std::getline(ss, c, ','))
    if (!c.empty()) v.push_back(c);
  return v;
}

// The lab's model_parameters.yml: `key: value` lines.
drops::realaigym::PlantParameters read_lab_parameters(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw drops::Error(path + ": cannot be read");
  std::map<std::string, double> v;
  std::string line;
  while (std::getline(in, line)) {
    const auto c = line.find(':');
    if (c == std::string::npos) continue;
    v[line.substr(0, c)] = std::stod(line.substr(c + 1));
  }
  auto at = [&](const char* k) {
    if (!v.count(k)) throw drops::Error(path + ": no '" + k + "'");
    return v.at(k);
  };
  drops::realaigym::PlantParameters p;
  p.mass = {at("m1"), at("m2")};
  p.length = {at("l1"), at("l2")};
  p.com = {at("r1"), at("r2")};
  p.inertia = {at("I1"), at("I2")};
  p.motor_inertia = at("Ir");
  p.gear_ratio = at("gr");
  p.damping = {at("b1"), at("b2")};
  p.coulomb = {at("cf1"), at("cf2")};
  p.gravity = at("g");
  p.torque_limit = {at("tl1"), at("tl2")};
  return p;
}

// The lab's model in its 10 base parameters (linear in them):
//   theta = [a1 = I1 + I2 + m2 l1^2 + (gr^2 + 1) Ir, a2 = I2 - gr Ir, a3 = I2 + gr^2 Ir,
//            k = m2 l1 r2, g1 = g (m1 r1 + m2 l1), g2 = g m2 r2, b1, cf1, b2, cf2]
//   M = [[a1 + 2 k c2, a2 + k c2], [a2 + k c2, a3]],
//   tau1 = M11 qdd1 + M12 qdd2 - k s2 (2 qd1 qd2 + qd2^2) + g1 s1 + g2 s12 + b1 qd1 + cf1 atan(100
//   qd1) tau2 = M21 qdd1 + M22 qdd2 + k s2 qd1^2 + g2 s12 + b2 qd2 + cf2 atan(100 qd2)
constexpr int kBase = 10;
const std::vector<std::string> kBaseNames = {"a1", "a2", "a3",  "k",  "g1",
                                             "g2", "b1", "cf1", "b2", "cf2"};

VectorXd base_of(const drops::realaigym::PlantParameters& p) {
  const double gr = p.gear_ratio, ir = p.motor_inertia, m2 = p.mass[1], l1 = p.length[0];
  VectorXd t(kBase);
  t << p.inertia[0] + p.inertia[1] + m2 * l1 * l1 + (gr * gr + 1) * ir, p.inertia[1] - gr * ir,
      p.inertia[1] + gr * gr * ir, m2 * l1 * p.com[1], p.gravity * (p.mass[0] * p.com[0] + m2 * l1),
      p.gravity * m2 * p.com[1], p.damping[0], p.coulomb[0], p.damping[1], p.coulomb[1];
  return t;
}

// The regressor: rows Y (2 x 10) with Y theta = tau at (q, qd, qdd).
Eigen::Matrix<double, 2, kBase> regressor(const Eigen::Vector4d& x, const Eigen::Vector2d& qdd) {
  const double q1 = x[0], q2 = x[1], qd1 = x[2], qd2 = x[3];
  const double c2 = std::cos(q2), s2 = std::sin(q2), s1 = std::sin(q1), s12 = std::sin(q1 + q2);
  Eigen::Matrix<double, 2, kBase> y = Eigen::Matrix<double, 2, kBase>::Zero();
  y(0, 0) = qdd[0];
  y(0, 1) = qdd[1];
  y(0, 3) = c2 * (2 * qdd[0] + qdd[1]) - s2 * (2 * qd1 * qd2 + qd2 * qd2);
  y(0, 4) = s1;
  y(0, 5) = s12;
  y(0, 6) = qd1;
  y(0, 7) = std::atan(100 * qd1);
  y(1, 1) = qdd[0];
  y(1, 2) = qdd[1];
  y(1, 3) = c2 * qdd[0] + s2 * qd1 * qd1;
  y(1, 5) = s12;
  y(1, 8) = qd2;
  y(1, 9) = std::atan(100 * qd2);
  return y;
}

Eigen::Vector2d base_accelerations(const VectorXd& t, const Eigen::Vector4d& x,
                                   const Eigen::Vector2d& tau) {
  // tau = M qdd + n: qdd = M^-1 (tau - n), n the regressor at qdd = 0.
  const Eigen::Vector2d n = regressor(x, Eigen::Vector2d::Zero()) * t;
  const double c2 = std::cos(x[1]);
  Eigen::Matrix2d m;
  m << t[0] + 2 * t[3] * c2, t[1] + t[3] * c2, t[1] + t[3] * c2, t[2];
  return m.inverse() * (tau - n);
}

// A model in base parameters (phi: the 10 entries) as a prior, RK4 over `substeps` per dt.
class BaseModel final : public drops::model::MeanFunction {
 public:
  BaseModel(double dt, int substeps) : dt_(dt), substeps_(substeps) {}
  int state_dim() const override { return 4; }
  int action_dim() const override { return 2; }
  std::vector<std::string> parameter_names() const override { return kBaseNames; }
  void check_phi(const VectorXd& phi) const override {
    drops::check_size("BaseModel phi", kBase, phi.size());
  }
  void evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                Eigen::Ref<VectorXd> dx) const override {
    const Eigen::Vector2d tau = u;
    auto f = [&](const Eigen::Vector4d& s) {
      Eigen::Vector4d d;
      d.head<2>() = s.tail<2>();
      d.tail<2>() = base_accelerations(phi, s, tau);
      return d;
    };
    const double h = dt_ / substeps_;
    Eigen::Vector4d s = x;
    for (int i = 0; i < substeps_; ++i) {
      const Eigen::Vector4d k1 = f(s), k2 = f(s + 0.5 * h * k1), k3 = f(s + 0.5 * h * k2),
                            k4 = f(s + h * k3);
      s += h * (k1 + 2 * (k2 + k3) + k4) / 6;
    }
    dx = s - x;
  }
  std::unique_ptr<drops::model::MeanFunction> clone() const override {
    return std::make_unique<BaseModel>(*this);
  }

 private:
  double dt_;
  int substeps_;
};

drops::model::PriorParameters fixed_parameters(const std::vector<std::string>& names,
                                               const VectorXd& values) {
  drops::model::PriorParameters p;
  p.names = names;
  p.values = values;
  p.lower = p.upper = VectorXd(0);
  return p;
}

struct Row {
  std::string model;
  double horizon;
  int dim;
  std::string state;
  double median, p90;
  int n;
};

// The errors pooled over the validation recordings' start points: prediction_errors on a log
// made of every validation log's segments (the same replay, the start points of each segment).
std::vector<Row> errors_of(const std::string& name, const drops::model::DynamicsModel& m,
                           const std::vector<ex::RecordedLog>& val,
                           const std::vector<double>& horizons, double spacing) {
  ex::RecordedLog all = val.front();
  all.segments.clear();
  for (const auto& l : val)
    all.segments.insert(all.segments.end(), l.segments.begin(), l.segments.end());
  std::vector<Row> out;
  for (const auto& e : ex::prediction_errors(m, all, "validation", horizons, spacing))
    out.push_back({name, e.horizon, e.dim, e.state, e.median, e.p90, e.n});
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::string data = DROPS_SOURCE_DIR "/tests/data/double-pendulum-dfki";
  std::vector<std::string> fit_ids = {"00", "01", "02", "04"}, val_ids = {"03", "05"};
  std::vector<std::string> models = {"urdf", "lab-1.0",  "lab-2.0", "lab-2.1", "ls",
                                     "gp",   "gp_prior", "mi",      "gp_mi"};
  int inducing = 200, gp_mi_max_points = 0, threads = 2;
  double ls_lowpass = 5, window = 0.02;
  std::string csv, phi_csv;
  std::vector<std::string> phi_names = {"Link1.inertia",   "Link2.inertia",   "Joint1.armature",
                                        "Joint2.armature", "Joint1.friction", "Joint2.friction"};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw drops::InvalidArgument(a + ": needs a value");
      return argv[++i];
    };
    if (a == "--fit")
      fit_ids = split(next());
    else if (a == "--validate")
      val_ids = split(next());
    else if (a == "--models")
      models = split(next());
    else if (a == "--phi")
      phi_names = split(next());
    else if (a == "--inducing")
      inducing = std::stoi(next());
    else if (a == "--gp-mi-max-points")
      gp_mi_max_points = std::stoi(next());
    else if (a == "--ls-lowpass")
      ls_lowpass = std::stod(next());
    else if (a == "--derivative-window")
      window = std::stod(next());
    else if (a == "--threads")
      threads = std::stoi(next());
    else if (a == "--csv")
      csv = next();
    else if (a == "--phi-csv")
      phi_csv = next();
    else if (a == "--data")
      data = next();
    else {
      std::fprintf(stderr, "dfki_identify: unknown argument '%s' (see the file's header)\n",
                   a.c_str());
      return 2;
    }
  }
  const double dt = 0.01;
  const std::vector<double> horizons = {0.1, 0.5, 1.0};
  const double spacing = 0.25;
  // The logs: angles from hanging, velocities the Savitzky-Golay derivative of the angles.
  ex::LogColumns cols;
  cols.time = "time";
  cols.state = {{"pos_meas1", ex::LogQuantity::kAngle, "", ""},
                {"pos_meas2", ex::LogQuantity::kAngle, "", ""},
                {"", ex::LogQuantity::kVelocity, "pos_meas1", "vel1"},
                {"", ex::LogQuantity::kVelocity, "pos_meas2", "vel2"}};
  cols.action = {"tau_meas1", "tau_meas2"};
  ex::LogOptions lo;
  lo.dt = dt;
  lo.derivative_window = window;
  auto path = [&](const std::string& id) { return data + "/sys_id/trajectory_" + id + ".csv"; };
  std::vector<ex::RecordedLog> fit, val;
  for (const auto& id : fit_ids) fit.push_back(ex::read_log(path(id), cols, lo));
  for (const auto& id : val_ids) val.push_back(ex::read_log(path(id), cols, lo));
  for (auto& l : fit) l.report.source = "fit";
  for (auto& l : val) l.report.source = "validation";

  std::vector<Row> rows;
  std::vector<std::string> phi_lines = {"model,name,value,lower95,upper95"};
  std::map<std::string, double> seconds;
  auto add = [&](const std::vector<Row>& r) { rows.insert(rows.end(), r.begin(), r.end()); };

  // The URDF prior and its six phi.
  drops::description::DescriptionPriorOptions po;
  po.file = data + "/double_pendulum.urdf";
  po.parameters = phi_names;
  auto urdf = std::make_shared<drops::description::DescriptionPrior>(po);
  drops::model::PriorParameters up;
  up.names = urdf->parameter_names();
  up.values = urdf->default_phi();
  // Bounds by kind: an inertia scale [0.01, 2], a damping or friction [0, 0.5], an armature
  // [0, 0.01] kg m^2.
  const auto P = static_cast<Eigen::Index>(phi_names.size());
  up.lower.resize(P);
  up.upper.resize(P);
  for (Eigen::Index i = 0; i < P; ++i) {
    const std::string& n = phi_names[static_cast<std::size_t>(i)];
    up.tunable.push_back(static_cast<int>(i));
    const bool inertia = n.find(".inertia") != std::string::npos;
    const bool armature = n.find(".armature") != std::string::npos;
    up.lower[i] = inertia ? 0.01 : 0;
    up.upper[i] = inertia ? 2 : armature ? 0.01 : 0.5;
  }
  up.choices.assign(phi_names.size(), {});
  auto base = std::make_shared<BaseModel>(dt, 10);
  for (std::size_t i = 0; i < up.names.size(); ++i)
    phi_lines.push_back(
        fmt::format("urdf,{},{},,", up.names[i], up.values[static_cast<Eigen::Index>(i)]));

  for (const auto& name : models) {
    const auto t0 = std::chrono::steady_clock::now();
    if (name == "urdf") {
      add(errors_of(name, *drops::model::make_prior_only_model(urdf, up), val, horizons, spacing));
    } else if (name.rfind("lab-", 0) == 0) {
      const auto p = read_lab_parameters(data + "/identified_parameters/model_" + name.substr(4) +
                                         "/model_parameters.yml");
      const VectorXd t = base_of(p);
      // The base-parameter model against the lab's equations (realaigym) at a few states.
      double worst = 0;
      for (int k = 0; k < 20; ++k) {
        const Eigen::Vector4d x(0.3 * k - 3, 0.5 * k - 4, 1 - 0.1 * k, 0.2 * k - 2);
        const Eigen::Vector2d tau(0.1 * k - 1, 0.5 - 0.05 * k);
        worst = std::max(worst, (base_accelerations(t, x, tau) -
                                 drops::realaigym::joint_accelerations(p, x, tau))
                                    .cwiseAbs()
                                    .maxCoeff());
      }
      if (worst > 1e-9)
        throw drops::Error(
            fmt::format("{}: the base-parameter model differs from the lab's "
                        "equations by {} rad/s^2",
                        name, worst));
      add(errors_of(name,
                    *drops::model::make_prior_only_model(base, fixed_parameters(kBaseNames, t)),
                    val, horizons, spacing));
      for (int i = 0; i < kBase; ++i)
        phi_lines.push_back(
            fmt::format("{},{},{},,", name, kBaseNames[static_cast<std::size_t>(i)], t[i]));
    } else if (name == "ls") {
      // Least squares on the fit logs low-passed: states at the midpoints of each period, the
      // accelerations their differences, the torque the period's average.
      ex::LogOptions ll = lo;
      ll.lowpass_hz = ls_lowpass;
      std::vector<Eigen::Matrix<double, 2, kBase>> ys;
      std::vector<Eigen::Vector2d> taus;
      for (const auto& id : fit_ids) {
        const ex::RecordedLog l = ex::read_log(path(id), cols, ll);
        for (const auto& s : l.segments)
          for (int k = 0; k < s.transitions(); ++k) {
            const Eigen::Vector4d x = 0.5 * (s.x.row(k) + s.x.row(k + 1)).transpose();
            const Eigen::Vector2d qdd =
                (s.x.row(k + 1).tail<2>() - s.x.row(k).tail<2>()).transpose() / dt;
            ys.push_back(regressor(x, qdd));
            taus.push_back(s.u.row(k).transpose());
          }
      }
      MatrixXd Y(2 * ys.size(), kBase);
      VectorXd T(2 * ys.size());
      for (std::size_t i = 0; i < ys.size(); ++i) {
        Y.middleRows(2 * static_cast<Eigen::Index>(i), 2) = ys[i];
        T.segment(2 * static_cast<Eigen::Index>(i), 2) = taus[i];
      }
      const VectorXd t = Y.colPivHouseholderQr().solve(T);
      const VectorXd r = Y * t - T;
      std::fprintf(stderr, "ls: %zu samples, low-pass %g Hz, torque residual RMS %.4f N m\n",
                   ys.size(), ls_lowpass,
                   std::sqrt(r.squaredNorm() / static_cast<double>(r.size())));
      for (int i = 0; i < kBase; ++i) {
        std::fprintf(stderr, "  %s = %.6g\n", kBaseNames[static_cast<std::size_t>(i)].c_str(),
                     t[i]);
        phi_lines.push_back(
            fmt::format("ls,{},{},,", kBaseNames[static_cast<std::size_t>(i)], t[i]));
      }
      add(errors_of(name,
                    *drops::model::make_prior_only_model(base, fixed_parameters(kBaseNames, t)),
                    val, horizons, spacing));
    } else {
      ex::IdentifyModel m;
      const auto type = name == "gp"         ? drops::model::ModelType::kGp
                        : name == "gp_prior" ? drops::model::ModelType::kGpPrior
                        : name == "mi"       ? drops::model::ModelType::kMi
                        : name == "gp_mi"    ? drops::model::ModelType::kGpMi
                                          : throw drops::InvalidArgument("unknown model " + name);
      m.type = name;
      m.options.type = type;
      m.options.inducing_points = inducing;
      m.options.gp_mi.max_points = gp_mi_max_points;
      m.task = ex::feature_task(4, 2, dt);
      m.prior = urdf;
      m.prior_dt = po.dt;
      m.parameters = up;
      ex::IdentifyOptions io;
      io.log = lo;
      io.columns = cols;
      io.horizons = horizons;
      io.start_spacing = spacing;
      io.threads = threads;
      io.logs = {"fit"};
      const ex::IdentifyResult r = ex::identify(
          m, fit, {}, io, [](const std::string& s) { std::fprintf(stderr, "%s\n", s.c_str()); });
      std::fprintf(stderr, "%s", r.summary.BriefReport().c_str());
      add(errors_of(name, *r.model, val, horizons, spacing));
      const auto& s = r.summary;
      for (Eigen::Index i = 0; i < s.phi.size(); ++i)
        phi_lines.push_back(fmt::format(
            "{},{},{},{},{}", name, s.phi_names[static_cast<std::size_t>(i)], s.phi[i],
            std::isfinite(s.phi_lower95[i]) ? fmt::format("{}", s.phi_lower95[i]) : "",
            std::isfinite(s.phi_upper95[i]) ? fmt::format("{}", s.phi_upper95[i]) : ""));
      seconds[name + " learn"] = s.learn_seconds;
    }
    seconds[name] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::fprintf(stderr, "%s: %.1f s\n", name.c_str(), seconds[name]);
  }

  // The table: per horizon and state, median / p90 of every model.
  std::printf("fit %s, validate %s, dt %g s, start points every %g s\n\n",
              fmt::format("{}", fmt::join(fit_ids, ",")).c_str(),
              fmt::format("{}", fmt::join(val_ids, ",")).c_str(), dt, spacing);
  std::printf("| horizon | state |");
  for (const auto& n : models) std::printf(" %s |", n.c_str());
  std::printf("\n|---|---|");
  for (std::size_t i = 0; i < models.size(); ++i) std::printf("---:|");
  std::printf("\n");
  std::vector<double> hs = {dt};
  hs.insert(hs.end(), horizons.begin(), horizons.end());
  for (double h : hs)
    for (int d = 0; d < 4; ++d) {
      std::string st;
      std::string line;
      for (const auto& n : models)
        for (const auto& r : rows)
          if (r.model == n && r.horizon == h && r.dim == d) {
            st = r.state;
            line += fmt::format(" {:.3g} / {:.3g} |", r.median, r.p90);
          }
      std::printf("| %g | %s |%s\n", h, st.c_str(), line.c_str());
    }
  for (const auto& n : models) std::printf("%s: %.1f s\n", n.c_str(), seconds[n]);
  if (!csv.empty()) {
    std::ofstream o(csv);
    o << "model,horizon,dim,state,median,p90,n\n";
    for (const auto& r : rows)
      o << fmt::format("{},{},{},{},{:.6g},{:.6g},{}\n", r.model, r.horizon, r.dim, r.state,
                       r.median, r.p90, r.n);
  }
  if (!phi_csv.empty()) {
    std::ofstream o(phi_csv);
    for (const auto& l : phi_lines) o << l << "\n";
    for (const auto& [k, v] : seconds) o << "# seconds," << k << "," << v << "\n";
  }
  return 0;
}

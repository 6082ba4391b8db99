#include "drops/description/description_prior.hpp"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <regex>
#include <sstream>

#include "drops/core/errors.hpp"

namespace drops::description {
namespace {

std::string join(const std::vector<std::string>& names) {
  if (names.empty()) return "(none)";
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InvalidArgument("description prior: cannot read the file '" + path + "'");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The text without its XML comments. (Plain scanning: std::regex recurses per character and
// overflows the stack on the long matches of a large file.)
std::string strip_comments(const std::string& text) {
  std::string out;
  size_t pos = 0;
  while (true) {
    const size_t open = text.find("<!--", pos);
    if (open == std::string::npos) break;
    out.append(text, pos, open - pos);
    const size_t close = text.find("-->", open + 4);
    if (close == std::string::npos) return out;  // an unclosed comment: MuJoCo will say so
    pos = close + 3;
  }
  out.append(text, pos, std::string::npos);
  return out;
}

// Whether text[pos] starts the element <tag (followed by a space, '>' or '/').
bool starts_element(const std::string& text, size_t pos, const std::string& tag) {
  if (text.compare(pos, tag.size() + 1, "<" + tag) != 0) return false;
  const size_t after = pos + tag.size() + 1;
  return after < text.size() && (std::isspace(static_cast<unsigned char>(text[after])) ||
                                 text[after] == '>' || text[after] == '/');
}

// The text without the elements <tag .../> and <tag ...>...</tag> (not nested in themselves).
std::string remove_elements(const std::string& text, const std::string& tag) {
  std::string out;
  size_t pos = 0, at = 0;
  while ((at = text.find("<" + tag, at)) != std::string::npos) {
    if (!starts_element(text, at, tag)) {
      ++at;
      continue;
    }
    const size_t gt = text.find('>', at);
    if (gt == std::string::npos) break;
    size_t end = gt + 1;
    if (text[gt - 1] != '/') {
      const size_t close = text.find("</" + tag, gt);
      if (close == std::string::npos) break;
      end = text.find('>', close);
      if (end == std::string::npos) break;
      ++end;
    }
    out.append(text, pos, at - pos);
    pos = at = end;
  }
  out.append(text, pos, std::string::npos);
  return out;
}

// The name of the root element of text without comments ("" if none).
std::string root_element(const std::string& text) {
  size_t at = 0;
  while ((at = text.find('<', at)) != std::string::npos) {
    ++at;
    if (at < text.size() && std::isalpha(static_cast<unsigned char>(text[at]))) {
      size_t end = at;
      while (end < text.size() && (std::isalnum(static_cast<unsigned char>(text[end])) ||
                                   text[end] == '_' || text[end] == '-' || text[end] == ':'))
        ++end;
      return text.substr(at, end - at);
    }
  }
  return "";
}

// The mesh files a URDF names (<mesh filename="...">, in <visual> or <collision>) that do not
// exist, relative to the file's folder (file:// stripped; package:// names are not resolved).
std::vector<std::string> missing_meshes(const std::string& text, const std::string& path) {
  std::vector<std::string> missing;
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  static const std::regex mesh("<mesh\\s[^>]*filename\\s*=\\s*\"([^\"]*)\"");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), mesh); it != std::sregex_iterator();
       ++it) {
    std::string name = (*it)[1].str();
    if (name.rfind("package://", 0) == 0) continue;
    if (name.rfind("file://", 0) == 0) name = name.substr(7);
    std::filesystem::path f(name);
    if (f.is_relative()) f = folder / f;
    std::error_code ec;
    if (!std::filesystem::exists(f, ec) &&
        std::find(missing.begin(), missing.end(), name) == missing.end())
      missing.push_back(name);
  }
  return missing;
}

// An error MuJoCo reports through mju_user_error (the default handler exits the process).
class EngineError : public Error {
 public:
  using Error::Error;
};

// Installed once per process, if the program has not installed its own: MuJoCo's fatal errors
// (an mjData stack overflow, an allocation failure) become exceptions that the calls below turn
// into a NumericalError naming the file. (MuJoCo's C code is compiled with unwind tables, and
// its own Python bindings throw from this hook the same way.)
void install_error_hook() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (mju_user_error == nullptr)
      mju_user_error = [](const char* message) { throw EngineError(message ? message : ""); };
  });
}

// A URDF as the prior loads it (DescriptionPriorOptions::file): no comments, collisions or
// visuals; the undeclared `world` link declared; fixed links kept as bodies of their own.
std::string prepare_urdf(const std::string& text) {
  std::string urdf = remove_elements(remove_elements(text, "collision"), "visual");
  size_t robot = 0;
  while ((robot = urdf.find("<robot", robot)) != std::string::npos &&
         !starts_element(urdf, robot, "robot"))
    ++robot;
  const size_t end = urdf.find('>', robot);
  std::string insert = "\n<mujoco><compiler fusestatic=\"false\" discardvisual=\"true\"/></mujoco>";
  // The DFKI file's joint base_weld names a parent link "world" that it does not declare, which
  // MuJoCo (and urdfdom) refuse: declare it.
  if (urdf.find("\"world\"") != std::string::npos &&
      !std::regex_search(urdf, std::regex("<link\\s+name\\s*=\\s*\"world\"")))
    insert += "\n<link name=\"world\"/>";
  urdf.insert(end + 1, insert);
  return urdf;
}

// mj_loadXML is not documented as thread-safe in MuJoCo 2.2: one load at a time.
std::mutex& load_mutex() {
  static std::mutex m;
  return m;
}

mjModel* load_model(const std::string& path, std::vector<std::string>& warnings) {
  const std::string text = strip_comments(read_text(path));
  const std::string root = root_element(text);
  if (root != "robot" && root != "mujoco")
    throw InvalidArgument("description prior: the file '" + path +
                          "' is neither a URDF (<robot>) nor an MJCF (<mujoco>) file: its root "
                          "element is " +
                          (root.empty() ? std::string("missing") : "<" + root + ">"));
  char error[1000] = "";
  mjModel* m = nullptr;
  std::lock_guard<std::mutex> lock(load_mutex());
  if (root == "robot") {
    if (const auto missing = missing_meshes(text, path); !missing.empty())
      warnings.push_back("description prior '" + path + "': the mesh files " + join(missing) +
                         " (of <visual> or <collision> elements) do not exist; ignored: the "
                         "prior uses no geometry (the links' <inertial> give the masses)");
    const std::string urdf = prepare_urdf(text);
    auto vfs = std::make_unique<mjVFS>();
    mj_defaultVFS(vfs.get());
    if (mj_makeEmptyFileVFS(vfs.get(), "robot.urdf", static_cast<int>(urdf.size())) != 0)
      throw InvalidArgument("description prior: '" + path + "': MuJoCo's VFS refused the file");
    std::memcpy(vfs->filedata[vfs->nfile - 1], urdf.data(), urdf.size());
    m = mj_loadXML("robot.urdf", vfs.get(), error, sizeof error);
    mj_deleteVFS(vfs.get());
  } else {
    m = mj_loadXML(path.c_str(), nullptr, error, sizeof error);
  }
  if (!m)
    throw InvalidArgument("description prior: the file '" + path +
                          "' does not load as a URDF or MJCF model: " + error);
  return m;
}

}  // namespace

namespace detail {

enum class Kind { kMass, kCom, kInertia, kDamping, kFriction, kArmature, kGear, kGravity };

struct Param {
  Kind kind;
  int index = 0;       // body id (mass, com, inertia) or dof address (joint kinds)
  int axis = 0;        // com: 0, 1, 2
  bool slide = false;  // joint kinds: a slide joint (N, m) rather than a hinge (N m, rad)
};

}  // namespace detail

namespace {

using detail::Kind;
using detail::Param;

constexpr const char* kBodyKinds[] = {"mass", "com.x", "com.y", "com.z", "inertia"};
constexpr const char* kJointKinds[] = {"damping", "friction", "armature", "gear"};

}  // namespace

bool DescriptionPriorOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (file.empty()) return fail("file: empty (a URDF or MJCF file is needed)");
  if (!(dt > 0) || !std::isfinite(dt)) return fail("dt: expected > 0 s, got " + std::to_string(dt));
  if (substeps < 1) return fail("substeps: expected >= 1, got " + std::to_string(substeps));
  if (!(coulomb_velocity > 0) || !std::isfinite(coulomb_velocity))
    return fail("coulomb_velocity: expected > 0, got " + std::to_string(coulomb_velocity));
  return true;
}

namespace detail {

struct PriorModel {
  DescriptionPriorOptions options;
  mjModel* model = nullptr;  // the file's, never written after the constructor
  std::vector<std::string> joints, actuated, bodies;
  std::vector<int> qpos, dof;  // per state joint
  std::vector<int> actuated_dof;
  std::vector<double> friction;  // per dof: the file's Coulomb friction (f_c)
  std::vector<Param> params;
  VectorXd defaults;
  std::vector<std::string> warnings;
  std::array<double, 3> gravity_direction{0, 0, -1};
  // No constraint can arise (no equality constraint, no limited tendon, no tendon friction loss;
  // joint limits, dof friction loss and contacts are off): a stage runs only the smooth pipeline
  // (stage_smooth) instead of the whole mj_forward.
  bool smooth_only = false;
  ~PriorModel() {
    if (model) mj_deleteModel(model);
  }
  std::string where() const { return "description prior '" + options.file + "'"; }
};

struct Workspace {
  mjModel* m = nullptr;
  mjData* d = nullptr;
  std::vector<double> friction, gear;  // per dof, phi written
  std::vector<double> tau;             // per dof: the driven joints' torques, gear applied
  // RK4 scratch: the state (q, v), a stage's (qs, vs), the four stages' derivatives (4 n each).
  std::vector<double> q, v, qs, vs, kq, kv;
  // The phi last written into m (valid when phi_written): a call with the same phi writes none.
  VectorXd phi;
  bool phi_written = false;
  explicit Workspace(const PriorModel& l) {
    m = mj_copyModel(nullptr, l.model);
    d = m ? mj_makeData(m) : nullptr;
    if (!d) {
      if (m) mj_deleteModel(m);
      throw NumericalError(l.where() + ": MuJoCo could not copy its model or make its data");
    }
    friction = l.friction;
    gear.assign(m->nv, 1.0);
    const size_t n = l.dof.size();
    for (auto* b : {&q, &v, &qs, &vs}) b->assign(n, 0.0);
    kq.assign(4 * n, 0.0);
    kv.assign(4 * n, 0.0);
    tau.assign(m->nv, 0.0);
  }
  ~Workspace() {
    if (d) mj_deleteData(d);
    if (m) mj_deleteModel(m);
  }
  Workspace(const Workspace&) = delete;
  Workspace& operator=(const Workspace&) = delete;
};

// Workspaces leased one per call: concurrent const calls never share one.
class WorkspacePool {
 public:
  explicit WorkspacePool(std::shared_ptr<const PriorModel> l) : loaded_(std::move(l)) {}
  struct Lease {
    WorkspacePool* pool;
    std::unique_ptr<Workspace> ws;
    int exceptions = std::uncaught_exceptions();
    ~Lease() {
      // A call that ends by an exception (MuJoCo's error hook threw out of mj_forward) may
      // leave its mjData half-written: that workspace is dropped, not reused.
      if (std::uncaught_exceptions() > exceptions) return;
      std::lock_guard<std::mutex> lock(pool->mutex_);
      pool->free_.push_back(std::move(ws));
    }
  };
  /// A workspace for one call, back in the pool when the lease ends without an exception.
  Lease lease() { return Lease{this, take()}; }

 private:
  std::unique_ptr<Workspace> take() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!free_.empty()) {
        auto ws = std::move(free_.back());
        free_.pop_back();
        return ws;
      }
    }
    return std::make_unique<Workspace>(*loaded_);
  }

  std::shared_ptr<const PriorModel> loaded_;
  std::mutex mutex_;
  std::vector<std::unique_ptr<Workspace>> free_;
};

}  // namespace detail

using detail::PriorModel;
using detail::Workspace;
using detail::WorkspacePool;

DescriptionPrior::DescriptionPrior(const DescriptionPriorOptions& options) {
  std::string why;
  if (!options.IsValid(&why))
    throw InvalidArgument("description prior '" + options.file + "': " + why);
  auto l = std::make_shared<PriorModel>();
  l->options = options;
  install_error_hook();
  l->model = load_model(options.file, l->warnings);
  mjModel* m = l->model;

  std::vector<std::string> file_joints;
  for (int j = 0; j < m->njnt; ++j) {
    const char* name = mj_id2name(m, mjOBJ_JOINT, j);
    file_joints.push_back(name ? name : "joint #" + std::to_string(j));
  }
  for (int j = 0; j < m->njnt; ++j) {
    if (m->jnt_type[j] == mjJNT_FREE)
      throw InvalidArgument(l->where() + ": the joint '" + file_joints[j] +
                            "' is free (a floating base); the prior needs a fixed base");
    if (m->jnt_type[j] == mjJNT_BALL)
      throw InvalidArgument(l->where() + ": the joint '" + file_joints[j] +
                            "' is a ball joint; the prior takes hinge and slide joints only");
  }
  for (int b = 1; b < m->nbody; ++b)
    if (const char* name = mj_id2name(m, mjOBJ_BODY, b)) l->bodies.push_back(name);

  auto joint_id = [&](const std::string& name, const char* what) {
    const int j = mj_name2id(m, mjOBJ_JOINT, name.c_str());
    if (j < 0)
      throw InvalidArgument(l->where() + ": " + what + ": no joint named '" + name +
                            "'; the file's joints: " + join(file_joints));
    return j;
  };
  std::vector<int> state_joints;
  if (options.joints.empty()) {
    for (int j = 0; j < m->njnt; ++j) state_joints.push_back(j);
  } else {
    for (const auto& name : options.joints) {
      const int j = joint_id(name, "joints");
      if (std::find(state_joints.begin(), state_joints.end(), j) != state_joints.end())
        throw InvalidArgument(l->where() + ": joints: '" + name + "' is listed twice");
      state_joints.push_back(j);
    }
    for (int j = 0; j < m->njnt; ++j)
      if (std::find(state_joints.begin(), state_joints.end(), j) == state_joints.end())
        throw InvalidArgument(l->where() + ": joints: the file's joint '" + file_joints[j] +
                              "' is not in the state (every joint that moves must be); the "
                              "file's joints: " +
                              join(file_joints));
  }
  if (state_joints.empty()) throw InvalidArgument(l->where() + ": the file has no joint");
  for (int j : state_joints) {
    l->joints.push_back(file_joints[j]);
    l->qpos.push_back(m->jnt_qposadr[j]);
    l->dof.push_back(m->jnt_dofadr[j]);
  }
  const auto& actuated = options.actuated.empty() ? l->joints : options.actuated;
  for (const auto& name : actuated) {
    const int j = joint_id(name, "actuated");
    const int d = m->jnt_dofadr[j];
    if (std::find(l->actuated_dof.begin(), l->actuated_dof.end(), d) != l->actuated_dof.end())
      throw InvalidArgument(l->where() + ": actuated: '" + name + "' is listed twice");
    l->actuated.push_back(name);
    l->actuated_dof.push_back(d);
  }

  // What the prior turns off: limits, contacts, MuJoCo's actuators; friction applied by drops.
  l->friction.assign(m->nv, 0.0);
  for (int d = 0; d < m->nv; ++d) {
    l->friction[d] = m->dof_frictionloss[d];
    m->dof_frictionloss[d] = 0;
  }
  for (int j = 0; j < m->njnt; ++j) m->jnt_limited[j] = 0;
  m->opt.disableflags |= mjDSBL_CONTACT | mjDSBL_ACTUATION;
  l->smooth_only = m->neq == 0;
  for (int t = 0; t < m->ntendon; ++t)
    if (m->tendon_limited[t] || m->tendon_frictionloss[t] > 0) l->smooth_only = false;
  const double g =
      std::sqrt(m->opt.gravity[0] * m->opt.gravity[0] + m->opt.gravity[1] * m->opt.gravity[1] +
                m->opt.gravity[2] * m->opt.gravity[2]);
  if (g > 0)
    for (int k = 0; k < 3; ++k) l->gravity_direction[k] = m->opt.gravity[k] / g;

  // phi by name.
  l->defaults.resize(static_cast<Eigen::Index>(options.parameters.size()));
  for (size_t i = 0; i < options.parameters.size(); ++i) {
    const std::string& name = options.parameters[i];
    Param p{Kind::kGravity};
    double value = g;
    const auto unknown = [&](const std::string& why) {
      return InvalidArgument(l->where() + ": parameter '" + name + "': " + why);
    };
    if (name != "gravity") {
      // <item>.<kind>, where the kind may itself hold a dot (com.x).
      std::string item, kind;
      for (const char* k : kBodyKinds)
        if (name.size() > std::strlen(k) + 1 && name.ends_with(std::string(".") + k)) kind = k;
      for (const char* k : kJointKinds)
        if (name.size() > std::strlen(k) + 1 && name.ends_with(std::string(".") + k)) kind = k;
      if (kind.empty())
        throw unknown(
            "not a parameter; a parameter is <body>.mass|com.x|com.y|com.z|inertia, "
            "<joint>.damping|friction|armature|gear or gravity");
      item = name.substr(0, name.size() - kind.size() - 1);
      const bool body_kind =
          std::find_if(std::begin(kBodyKinds), std::end(kBodyKinds),
                       [&](const char* k) { return kind == k; }) != std::end(kBodyKinds);
      if (body_kind) {
        const int b = mj_name2id(m, mjOBJ_BODY, item.c_str());
        if (b <= 0)
          throw unknown("no body (link) named '" + item +
                        "'; the file's bodies: " + join(l->bodies));
        p.index = b;
        if (kind == "mass") {
          p.kind = Kind::kMass;
          value = m->body_mass[b];
        } else if (kind == "inertia") {
          p.kind = Kind::kInertia;
          value = 1.0;
        } else {
          p.kind = Kind::kCom;
          p.axis = kind.back() - 'x';
          value = m->body_ipos[3 * b + p.axis];
        }
      } else {
        const int j = mj_name2id(m, mjOBJ_JOINT, item.c_str());
        if (j < 0)
          throw unknown("no joint named '" + item + "'; the file's joints: " + join(file_joints));
        const int d = m->jnt_dofadr[j];
        p.index = d;
        p.slide = m->jnt_type[j] == mjJNT_SLIDE;
        if (kind == "damping") {
          p.kind = Kind::kDamping;
          value = m->dof_damping[d];
        } else if (kind == "friction") {
          p.kind = Kind::kFriction;
          value = l->friction[d];
        } else if (kind == "armature") {
          p.kind = Kind::kArmature;
          value = m->dof_armature[d];
        } else {
          if (std::find(l->actuated_dof.begin(), l->actuated_dof.end(), d) == l->actuated_dof.end())
            throw unknown("the joint '" + item +
                          "' is not driven; the driven joints: " + join(l->actuated));
          p.kind = Kind::kGear;
          value = 1.0;
        }
      }
    }
    for (size_t k = 0; k < i; ++k)
      if (options.parameters[k] == name) throw unknown("listed twice");
    l->params.push_back(p);
    l->defaults[static_cast<Eigen::Index>(i)] = value;
  }
  loaded_ = std::move(l);
  pool_ = std::make_unique<WorkspacePool>(loaded_);
}

DescriptionPrior::~DescriptionPrior() = default;

DescriptionPrior::DescriptionPrior(const DescriptionPrior& other)
    : model::MeanFunction(other),
      loaded_(other.loaded_),
      pool_(std::make_unique<WorkspacePool>(loaded_)) {
  try {
    pool_->lease();  // one workspace ready: copies the model and makes its data
  } catch (const EngineError& e) {
    throw NumericalError(loaded_->where() + ": MuJoCo: " + e.what());
  }
}

int DescriptionPrior::state_dim() const { return 2 * static_cast<int>(loaded_->joints.size()); }
int DescriptionPrior::action_dim() const { return static_cast<int>(loaded_->actuated.size()); }
std::vector<std::string> DescriptionPrior::parameter_names() const {
  return loaded_->options.parameters;
}
const std::vector<std::string>& DescriptionPrior::joint_names() const { return loaded_->joints; }
const std::vector<std::string>& DescriptionPrior::actuated_joint_names() const {
  return loaded_->actuated;
}
std::vector<std::string> DescriptionPrior::body_names() const { return loaded_->bodies; }
const DescriptionPriorOptions& DescriptionPrior::options() const { return loaded_->options; }
VectorXd DescriptionPrior::default_phi() const { return loaded_->defaults; }

std::vector<std::string> DescriptionPrior::available_parameters() const {
  std::vector<std::string> names;
  for (const auto& b : loaded_->bodies)
    for (const char* k : kBodyKinds) names.push_back(b + "." + k);
  for (const auto& j : loaded_->joints) {
    for (const char* k : kJointKinds) {
      if (std::string(k) == "gear" && std::find(loaded_->actuated.begin(), loaded_->actuated.end(),
                                                j) == loaded_->actuated.end())
        continue;
      names.push_back(j + "." + k);
    }
  }
  names.push_back("gravity");
  return names;
}

ParameterDomain DescriptionPrior::parameter_domain(int i) const {
  const auto& l = *loaded_;
  if (i < 0 || i >= static_cast<int>(l.params.size()))
    throw InvalidArgument(l.where() + ": parameter index " + std::to_string(i) +
                          ": expected 0 to " + std::to_string(l.params.size()) + " - 1");
  const Param& p = l.params[static_cast<size_t>(i)];
  const double inf = std::numeric_limits<double>::infinity();
  switch (p.kind) {
    case Kind::kMass:
      return {0, false, inf, "kg", "a mass"};
    case Kind::kCom:
      return {-inf, false, inf, "m", "a centre-of-mass coordinate"};
    case Kind::kInertia:
      return {0, true, inf, "", "an inertia scale (1 = the file's)"};
    case Kind::kDamping:
      return {0, false, inf, p.slide ? "N s/m" : "N m s/rad", "a viscous damping"};
    case Kind::kFriction:
      return {0, false, inf, p.slide ? "N" : "N m", "a Coulomb friction"};
    case Kind::kArmature:
      return {0, false, inf, p.slide ? "kg" : "kg m^2", "an armature (rotor inertia)"};
    case Kind::kGear:
      return {-inf, false, inf, "", "a gear (torque per unit of action)"};
    case Kind::kGravity:
      return {0, false, inf, "m/s^2", "a gravity"};
  }
  return {};
}

int DescriptionPrior::parameter_index(const std::string& name) const {
  const auto& names = loaded_->options.parameters;
  const auto it = std::find(names.begin(), names.end(), name);
  return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}

namespace {

// "a mass: >= 0 kg" and whether v lies in the domain.
std::string domain_text(const ParameterDomain& d) {
  std::ostringstream o;
  o << d.what << ": ";
  if (std::isfinite(d.lower))
    o << (d.lower_open ? "> " : ">= ") << d.lower << (d.unit.empty() ? "" : " " + d.unit);
  else
    o << "any finite value";
  return o.str();
}

bool in_domain(const ParameterDomain& d, double v) {
  return std::isfinite(v) && (d.lower_open ? v > d.lower : v >= d.lower) && v <= d.upper;
}

}  // namespace

void DescriptionPrior::check_bounds(int i, double lower, double upper) const {
  const auto& l = *loaded_;
  const ParameterDomain d = parameter_domain(i);
  const std::string& name = l.options.parameters[static_cast<size_t>(i)];
  std::ostringstream o;
  o << l.where() << ": " << name << ": bounds [" << lower << ", " << upper << "]: ";
  if (!std::isfinite(lower) || !std::isfinite(upper))
    throw InvalidArgument(o.str() + "expected finite bounds");
  if (lower > upper) throw InvalidArgument(o.str() + "expected lower <= upper");
  if (!in_domain(d, lower) || !in_domain(d, upper))
    throw InvalidArgument(o.str() + "non-physical: " + domain_text(d));
}

const std::vector<std::string>& DescriptionPrior::warnings() const { return loaded_->warnings; }

void DescriptionPrior::check_phi(const VectorXd& phi) const {
  const auto& l = *loaded_;
  if (phi.size() != static_cast<Eigen::Index>(l.params.size()))
    throw InvalidArgument(l.where() + ": phi: expected size " + std::to_string(l.params.size()) +
                          ", got " + std::to_string(phi.size()));
  for (size_t i = 0; i < l.params.size(); ++i) {
    const double v = phi[static_cast<Eigen::Index>(i)];
    const ParameterDomain d = parameter_domain(static_cast<int>(i));
    if (!in_domain(d, v)) {
      std::ostringstream o;
      o << l.where() << ": " << l.options.parameters[i] << " = " << v << ": expected "
        << (std::isfinite(v) ? domain_text(d) : "a finite value");
      throw InvalidArgument(o.str());
    }
  }
}

// Writes phi into the workspace's model (every phi entry, so what a previous call wrote is
// overwritten; the rest stays the file's).
namespace {

void write_phi_impl(const mjModel* file, const std::vector<Param>& params,
                    const std::array<double, 3>& gdir, mjModel* m, std::vector<double>& friction,
                    std::vector<double>& gear, const VectorXd& phi) {
  for (size_t i = 0; i < params.size(); ++i) {
    const double v = phi[static_cast<Eigen::Index>(i)];
    const Param& p = params[i];
    switch (p.kind) {
      case Kind::kMass:
        m->body_mass[p.index] = v;
        break;
      case Kind::kCom:
        m->body_ipos[3 * p.index + p.axis] = v;
        break;
      case Kind::kInertia:
        for (int k = 0; k < 3; ++k)
          m->body_inertia[3 * p.index + k] = v * file->body_inertia[3 * p.index + k];
        break;
      case Kind::kDamping:
        m->dof_damping[p.index] = v;
        break;
      case Kind::kFriction:
        friction[p.index] = v;
        break;
      case Kind::kArmature:
        m->dof_armature[p.index] = v;
        break;
      case Kind::kGear:
        gear[p.index] = v;
        break;
      case Kind::kGravity:
        for (int k = 0; k < 3; ++k) m->opt.gravity[k] = v * gdir[k];
        break;
    }
  }
}

// Writes phi into w's model unless w holds that phi already (a run calls with the same phi for
// many calls in a row: GP-MI changes phi once per policy evaluation at most).
void write_phi(const PriorModel& l, Workspace& w, const VectorXd& phi) {
  if (w.phi_written && w.phi.size() == phi.size() && w.phi == phi) return;
  w.phi_written = false;  // until written in full
  write_phi_impl(l.model, l.params, l.gravity_direction, w.m, w.friction, w.gear, phi);
  w.phi = phi;
  w.phi_written = true;
}

// The driven joints' torques of u (u[a * stride], a < m) into w.tau (per dof, gear applied).
void set_torques(const PriorModel& l, Workspace& w, const double* u, Eigen::Index stride) {
  std::fill(w.tau.begin(), w.tau.end(), 0.0);
  for (size_t a = 0; a < l.actuated_dof.size(); ++a) {
    const int d = l.actuated_dof[a];
    w.tau[d] = w.gear[d] * u[static_cast<Eigen::Index>(a) * stride];
  }
}

// qdd at (q, v) (dim n each) into acc (dim n): the driven joints' torques in w.tau (per dof,
// gear applied), the smooth Coulomb friction added here. When no constraint can arise
// (l.smooth_only), only the pieces of mj_forward that the smooth dynamics need run: position
// (mj_kinematics, mj_comPos, mj_tendon, mj_crb with the armature, mj_factorM), velocity
// (mj_fwdVelocity: tendon velocities, mj_comVel, mj_passive with damping and springs, mj_rne for
// the bias c + g), then qacc = M^-1 (qfrc_passive - qfrc_bias + qfrc_applied) as
// mj_fwdAcceleration sums it (its actuator and body-force terms are zero here: actuation off,
// xfrc_applied never set), and mj_fwdConstraint's copy with no constraint. Skipped: sensors,
// energy, cameras and lights, collision (contacts off), constraint assembly and projection,
// actuator transmission and forces. The same floating-point operations as mj_forward on such a
// model, so the same qacc bit for bit (MuJoCo 2.2.2).
void forward(const PriorModel& l, Workspace& w, const double* q, const double* v, double* acc) {
  mjModel* m = w.m;
  mjData* d = w.d;
  const size_t n = l.dof.size();
  for (size_t i = 0; i < n; ++i) {
    d->qpos[l.qpos[i]] = q[i];
    d->qvel[l.dof[i]] = v[i];
  }
  const double vs = l.options.coulomb_velocity;
  for (int k = 0; k < m->nv; ++k)
    d->qfrc_applied[k] =
        w.friction[k] == 0 ? w.tau[k] : w.tau[k] - w.friction[k] * std::tanh(d->qvel[k] / vs);
  if (l.smooth_only) {
    mj_kinematics(m, d);
    mj_comPos(m, d);
    if (m->ntendon) mj_tendon(m, d);
    mj_crb(m, d);
    mj_factorM(m, d);
    mj_fwdVelocity(m, d);
    for (int k = 0; k < m->nv; ++k)
      d->qfrc_smooth[k] = d->qfrc_passive[k] - d->qfrc_bias[k] + d->qfrc_applied[k];
    mj_solveM(m, d, d->qacc, d->qfrc_smooth, 1);
  } else {
    mj_forward(m, d);
  }
  for (size_t i = 0; i < n; ++i) acc[i] = d->qacc[l.dof[i]];
}

// One control period from (w.q, w.v) under w.tau, in place: `substeps` steps of classical RK4.
void integrate(const PriorModel& l, Workspace& w) {
  const int n = static_cast<int>(l.dof.size());
  const double h = l.options.dt / l.options.substeps;
  auto &kq = w.kq, &kv = w.kv, &qs = w.qs, &vs = w.vs;
  for (int s = 0; s < l.options.substeps; ++s) {
    // Classical RK4 on (q, v): stage c at (q + a_c h kq_{c-1}, v + a_c h kv_{c-1}).
    for (int c = 0; c < 4; ++c) {
      const double a = c == 0 ? 0.0 : (c == 3 ? h : 0.5 * h);
      for (int i = 0; i < n; ++i) {
        qs[i] = w.q[i] + (c ? a * kq[(c - 1) * n + i] : 0.0);
        vs[i] = w.v[i] + (c ? a * kv[(c - 1) * n + i] : 0.0);
        kq[c * n + i] = vs[i];
      }
      forward(l, w, qs.data(), vs.data(), &kv[c * n]);
    }
    for (int i = 0; i < n; ++i) {
      w.q[i] += h / 6 * (kq[i] + 2 * kq[n + i] + 2 * kq[2 * n + i] + kq[3 * n + i]);
      w.v[i] += h / 6 * (kv[i] + 2 * kv[n + i] + 2 * kv[2 * n + i] + kv[3 * n + i]);
    }
  }
}

}  // namespace

void DescriptionPrior::evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                                Eigen::Ref<VectorXd> dx) const {
  // One state: no matrices (evaluate_batch's work on a single row, without its allocations).
  const auto& l = *loaded_;
  const int n = static_cast<int>(l.dof.size());
  check_size("description prior: x (2 x the joints)", 2 * n, x.size());
  check_size("description prior: u (the driven joints)", static_cast<long>(l.actuated_dof.size()),
             u.size());
  check_size("description prior: phi", static_cast<long>(l.params.size()), phi.size());
  check_size("description prior: dx (2 x the joints)", 2 * n, dx.size());
  try {
    auto lease = pool_->lease();
    Workspace& w = *lease.ws;
    write_phi(l, w, phi);
    set_torques(l, w, u.data(), 1);
    for (int i = 0; i < n; ++i) {
      w.q[i] = x[i];
      w.v[i] = x[n + i];
    }
    integrate(l, w);
    for (int i = 0; i < n; ++i) {
      dx[i] = w.q[i] - x[i];
      dx[n + i] = w.v[i] - x[n + i];
    }
  } catch (const EngineError& e) {
    throw NumericalError(l.where() + ": MuJoCo: " + e.what());
  }
}

void DescriptionPrior::evaluate_batch(const MatrixXd& X, const MatrixXd& U, const VectorXd& phi,
                                      MatrixXd& dX) const {
  const auto& l = *loaded_;
  const int n = static_cast<int>(l.dof.size());
  check_size("description prior: X's columns (2 x the joints)", 2 * n, X.cols());
  check_size("description prior: U's columns (the driven joints)",
             static_cast<long>(l.actuated_dof.size()), U.cols());
  check_size("description prior: U's rows (one per row of X)", X.rows(), U.rows());
  check_size("description prior: phi", static_cast<long>(l.params.size()), phi.size());
  try {
    evaluate_rows(X, U, phi, dX);
  } catch (const EngineError& e) {
    throw NumericalError(l.where() + ": MuJoCo: " + e.what());
  }
}

void DescriptionPrior::evaluate_rows(const MatrixXd& X, const MatrixXd& U, const VectorXd& phi,
                                     MatrixXd& dX) const {
  const auto& l = *loaded_;
  const int n = static_cast<int>(l.dof.size());
  auto lease = pool_->lease();
  Workspace& w = *lease.ws;
  write_phi(l, w, phi);
  dX.resize(X.rows(), 2 * n);
  for (Eigen::Index b = 0; b < X.rows(); ++b) {
    set_torques(l, w, U.data() + b, U.rows());  // row b of the column-major U
    for (int i = 0; i < n; ++i) {
      w.q[i] = X(b, i);
      w.v[i] = X(b, n + i);
    }
    integrate(l, w);
    for (int i = 0; i < n; ++i) {
      dX(b, i) = w.q[i] - X(b, i);
      dX(b, n + i) = w.v[i] - X(b, n + i);
    }
  }
}

VectorXd DescriptionPrior::joint_accelerations(const VectorXd& x, const VectorXd& u,
                                               const VectorXd& phi) const {
  const auto& l = *loaded_;
  const int n = static_cast<int>(l.dof.size());
  check_size("description prior: x (2 x the joints)", 2 * n, x.size());
  check_size("description prior: u (the driven joints)", static_cast<long>(l.actuated_dof.size()),
             u.size());
  check_size("description prior: phi", static_cast<long>(l.params.size()), phi.size());
  VectorXd acc(n);
  try {
    auto lease = pool_->lease();
    Workspace& w = *lease.ws;
    write_phi(l, w, phi);
    set_torques(l, w, u.data(), 1);
    forward(l, w, x.data(), x.data() + n, acc.data());
  } catch (const EngineError& e) {
    throw NumericalError(l.where() + ": MuJoCo: " + e.what());
  }
  return acc;
}

std::unique_ptr<model::MeanFunction> DescriptionPrior::clone() const {
  return std::make_unique<DescriptionPrior>(*this);
}

}  // namespace drops::description

// hexapod_animate: replays one recorded episode of a hexapod run directory in DART's OSG viewer and
// writes it as an animated GIF (one frame per measured state, 0.1 s apart: real time). Built only
// when DART's gui-osg component is installed (scripts/install-deps --render); needs a display, so
// run it under Xvfb on a machine without one:
//
//   xvfb-run -a build/tasks/hexapod/tools/hexapod_animate RUN_DIR EPISODE [--output FILE.gif]
//
// The robot is the run's "real" robot (config.yaml: hexapod.damage.*), placed at each recorded
// state of episodes/NNN/real.csv (the measured states, noise included). The camera looks at the
// middle of the body's path from the side and behind. Frames are rendered to a temporary folder
// and joined by Pillow (Debian's /usr/bin/python3, python3-pil, a dependency of matplotlib).
// DART translation unit: no -march=native (see CMakeLists.txt).

#include <dart/dynamics/BodyNode.hpp>
#include <dart/dynamics/ShapeNode.hpp>
#include <dart/dynamics/Skeleton.hpp>
#include <dart/gui/osg/osg.hpp>
#include <dart/simulation/World.hpp>

#include <cstdio>
#include <cstdlib>
#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/experiment/config.hpp"
#include "drops/experiment/run_directory.hpp"
#include "drops/hexapod/plugin.hpp"
#include "drops/hexapod/robot.hpp"
#include "drops/hexapod/simulator.hpp"

namespace fs = std::filesystem;
namespace hx = drops::hexapod;

namespace {

// The 48-D states of a real.csv (columns t, then the state), read with the run-directory reader.
std::vector<Eigen::VectorXd> read_states(const fs::path& path) {
  const drops::experiment::TrajectoryTable t = drops::experiment::read_trajectory_csv(path);
  if (t.columns.size() < 1 + static_cast<std::size_t>(hx::kStateDim))
    throw drops::Error(path.string() + " has fewer than 49 columns: not a hexapod trajectory");
  std::vector<Eigen::VectorXd> states;
  for (const auto& row : t.rows) {
    Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(row.data() + 1, hx::kStateDim);
    if (!x.allFinite()) break;  // a recorded non-finite state ends the replay
    states.push_back(x);
  }
  if (states.empty()) throw drops::Error(path.string() + " holds no state");
  return states;
}

int usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s RUN_DIR EPISODE [--output FILE.gif]\n"
               "  replays episode EPISODE of the hexapod run in RUN_DIR (its real.csv) in DART's\n"
               "  OSG viewer and writes an animated GIF (default RUN_DIR/episodes/NNN/real.gif).\n"
               "  Needs a display: run it under xvfb-run -a on a headless machine.\n",
               argv0);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3 && argc != 5) return usage(argv[0]);
  if (argc == 5 && std::string(argv[3]) != "--output") return usage(argv[0]);
  try {
    const fs::path run = argv[1];
    const int episode = std::atoi(argv[2]);
    if (episode < 1) throw drops::ConfigError("EPISODE must be a number >= 1");
    char folder[16];
    std::snprintf(folder, sizeof folder, "%03d", episode);
    const fs::path csv = run / "episodes" / folder / "real.csv";
    const fs::path output = argc == 5 ? fs::path(argv[4]) : run / "episodes" / folder / "real.gif";

    drops::experiment::Registry registry;
    drops::experiment::register_builtin_algorithms(registry);
    hx::register_task(registry);
    const drops::experiment::Settings settings =
        drops::experiment::load_settings_file(registry, (run / "config.yaml").string(), {});
    if (settings.at("task") != "hexapod")
      throw drops::ConfigError(run.string() + " is not a hexapod run");
    const std::vector<Eigen::VectorXd> states = read_states(csv);

    hx::PriorSimulator sim(hx::real_robot_spec(settings));
    // Colours: a grey ground, a dark body, orange legs.
    const auto world = sim.world();
    for (std::size_t k = 0; k < world->getNumSkeletons(); ++k) {
      const auto skel = world->getSkeleton(k);
      for (std::size_t b = 0; b < skel->getNumBodyNodes(); ++b) {
        dart::dynamics::BodyNode* body = skel->getBodyNode(b);
        const Eigen::Vector3d colour = skel->getName() == hx::kGroundName ? Eigen::Vector3d(0.8, 0.8, 0.78)
                                       : body->getName() == hx::kBodyName ? Eigen::Vector3d(0.2, 0.25, 0.3)
                                                                          : Eigen::Vector3d(0.95, 0.55, 0.1);
        for (dart::dynamics::ShapeNode* shape : body->getShapeNodesWith<dart::dynamics::VisualAspect>())
          shape->getVisualAspect()->setColor(colour);
      }
    }
    ::osg::ref_ptr<dart::gui::osg::WorldNode> node = new dart::gui::osg::WorldNode(sim.world());
    node->simulate(false);
    dart::gui::osg::Viewer viewer;
    viewer.addWorldNode(node);
    viewer.setUpViewInWindow(0, 0, 800, 600);

    // Camera: from behind-right and above the middle of the path, far enough to see all of it.
    Eigen::Vector2d lo(states.front()[hx::kBodyPos], states.front()[hx::kBodyPos + 1]), hi = lo;
    for (const auto& x : states) {
      lo = lo.cwiseMin(x.segment<2>(hx::kBodyPos));
      hi = hi.cwiseMax(x.segment<2>(hx::kBodyPos));
    }
    const Eigen::Vector2d mid = (lo + hi) / 2;
    const double d = std::max(1.5, 2.0 * (hi - lo).norm());
    viewer.getCameraManipulator()->setHomePosition(
        ::osg::Vec3d(mid.x() - 0.6 * d, mid.y() - 0.9 * d, 0.6 * d),
        ::osg::Vec3d(mid.x(), mid.y(), 0.1), ::osg::Vec3d(0, 0, 1));
    viewer.setCameraManipulator(viewer.getCameraManipulator());

    const fs::path frames = fs::temp_directory_path() / ("hexapod_animate-" + std::to_string(getpid()));
    fs::remove_all(frames);
    fs::create_directories(frames);
    viewer.realize();
    viewer.home();
    viewer.frame();  // one frame before recording: the window and its buffers exist
    viewer.record(frames.string(), "frame", true, 4);
    for (const auto& x : states) {
      sim.set_state(x);
      viewer.frame();
    }
    viewer.pauseRecording();

    const std::string join =
        "/usr/bin/python3 -c \"import sys, glob; from PIL import Image; "
        "f = [Image.open(p).convert('P', palette=Image.ADAPTIVE) for p in sorted(glob.glob(sys.argv[1] + '/frame*.png'))]; "
        "f[0].save(sys.argv[2], save_all=True, append_images=f[1:], duration=100, loop=0)\" '" +
        frames.string() + "' '" + output.string() + "'";
    const int rc = std::system(join.c_str());
    const auto n = std::distance(fs::directory_iterator(frames), fs::directory_iterator{});
    fs::remove_all(frames);
    if (rc != 0)
      throw drops::Error("joining the " + std::to_string(n) +
                         " frames failed (needs /usr/bin/python3 with python3-pil)");
    std::cerr << "hexapod_animate: " << states.size() << " states, " << n << " frames -> "
              << output.string() << "\n";
  } catch (const drops::ConfigError& ex) {
    std::cerr << "hexapod_animate: configuration error: " << ex.what() << "\n";
    return 2;
  } catch (const std::exception& ex) {
    std::cerr << "hexapod_animate: " << ex.what() << "\n";
    return 1;
  }
  return 0;
}

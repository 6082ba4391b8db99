// The drops command line: the built-in tasks and algorithms, registered explicitly.
//   run       an algorithm on one configured experiment (run_command.cpp), also --resume DIR
//   config    the resolved configuration or the schema as Markdown (run_command.cpp)
//   campaign  a grid of runs in parallel processes or over MPI (campaign.cpp)
//   report    aggregated tables and figures of a campaign (report_command.cpp)
//   plot      figures of one run (report_command.cpp)
//   direct    `run algorithm=direct` under its own name (direct_command.cpp)

#include "drops/cli.hpp"
#include "drops/core/parallel.hpp"
#include "drops/experiment/registry.hpp"
#include "drops/pendubot/plugin.hpp"
#include "drops/realaigym/plugin.hpp"
#ifdef DROPS_WITH_HEXAPOD
#include "drops/hexapod/plugin.hpp"
#endif
#ifdef DROPS_WITH_MUJOCO
#include "drops/description/experiment_factory.hpp"
#endif

int main(int argc, char** argv) {
  drops::use_single_threaded_blas();
  drops::experiment::Registry registry;
  drops::experiment::register_builtin_algorithms(registry);
  drops::pendubot::register_task(registry);  // the default task
  drops::realaigym::register_task(registry);
#ifdef DROPS_WITH_HEXAPOD
  drops::hexapod::register_task(registry);
#else
  registry.add_unavailable_task(
      "hexapod", "this drops was built without DART 6; run scripts/install-deps, then "
                 "scripts/build again");
#endif
#ifdef DROPS_WITH_MUJOCO
  // prior.model: a URDF or MJCF file as the simulator prior (drops::description, MuJoCo).
  registry.set_description_prior_factory(drops::description::experiment_factory());
#endif
  return drops::cli::run(argc, argv, registry);
}

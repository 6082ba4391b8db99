// cartpole_drops: the drops command line with the cart-pole registered first (the default task),
// then drops's own tasks.
#include "drops/cli.hpp"
#include "drops/core/parallel.hpp"
#include "drops/experiment/registry.hpp"
#include "drops/pendubot/plugin.hpp"

namespace cartpole {
void register_task(drops::experiment::Registry& registry);  // plugin.cpp
}

int main(int argc, char** argv) {
  drops::use_single_threaded_blas();
  drops::experiment::Registry registry;
  drops::experiment::register_builtin_algorithms(registry);
  cartpole::register_task(registry);
  drops::pendubot::register_task(registry);
  return drops::cli::run(argc, argv, registry, "cartpole_drops");
}

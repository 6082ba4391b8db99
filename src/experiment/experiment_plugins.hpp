#pragma once
// The built-in algorithm plugins defined in their own files (internal to drops::experiment).
#include <memory>

#include "drops/experiment/registry.hpp"

namespace drops::experiment {

/// IT&E (algorithm=ite; src/experiment/ite_plugin.cpp).
std::unique_ptr<AlgorithmPlugin> make_ite_plugin();

}  // namespace drops::experiment

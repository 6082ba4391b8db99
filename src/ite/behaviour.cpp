// A task's behaviour space for MAP-Elites.
#include "drops/ite/behaviour.hpp"

#include "drops/core/errors.hpp"

namespace drops::ite {

void BehaviourDescriptor::check() const {
  if (!describe) throw InvalidArgument("behaviour descriptor: expected a describe function, got none");
  if (bins.empty()) throw InvalidArgument("behaviour descriptor: expected at least one dimension");
  check_size("behaviour descriptor: names vs bins", static_cast<Eigen::Index>(bins.size()),
             static_cast<Eigen::Index>(names.size()));
  for (std::size_t d = 0; d < bins.size(); ++d)
    if (bins[d] < 1)
      throw InvalidArgument("behaviour descriptor: expected >= 1 bins in dimension " +
                            std::to_string(d) + " (" + names[d] + "), got " +
                            std::to_string(bins[d]));
}

}  // namespace drops::ite

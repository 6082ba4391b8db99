#pragma once
/// \file DescriptionPrior as the experiment layer's factory of description-file priors
/// (prior.model; drops/experiment/description_prior.hpp): what an application registers with
/// Registry::set_description_prior_factory when it is built with MuJoCo. Header-only: its user
/// links drops::description and drops::experiment.

#include <memory>

#include "drops/description/description_prior.hpp"
#include "drops/experiment/description_prior.hpp"

namespace drops::description {

/// The factory: a DescriptionPrior of the request (its file, joints, actuated joints, phi's
/// names, dt, substeps, Coulomb velocity scale), the file's values of phi and the joints' names.
/// Throws InvalidArgument as DescriptionPrior's constructor (naming the file and the item).
/// Thread-safe.
inline experiment::DescriptionPriorFactory experiment_factory() {
  return [](const experiment::DescriptionPriorRequest& r) {
    DescriptionPriorOptions o;
    o.file = r.file;
    o.joints = r.joints;
    o.actuated = r.actuated;
    o.parameters = r.parameters;
    o.dt = r.dt;
    o.substeps = r.substeps;
    o.coulomb_velocity = r.coulomb_velocity;
    auto prior = std::make_shared<const DescriptionPrior>(o);
    experiment::DescriptionPriorModel m;
    m.file_values = prior->default_phi();
    m.joints = prior->joint_names();
    m.actuated = prior->actuated_joint_names();
    m.prior = std::move(prior);
    return m;
  };
}

}  // namespace drops::description

#pragma once
/// The contracts of what the registry accepts (physics/register_all.cpp), as C++20 concepts: a law,
/// bond law, module, generator or monitor that misses a member fails to compile at its
/// registry row, with the concept's name in the message. The optional members of laws (the
/// `requires` checks in contact_model.hpp and bond_model.hpp) stay optional.
#include <concepts>
#include <string>
#include <string_view>
#include <vector>

#include "engine/contact/bond_model.hpp"
#include "engine/contact/contact_model.hpp"
#include "engine/model/generator.hpp"
#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"
#include "engine/simulation.hpp"

namespace sparkdem {

/// Described by parameters: `struct Params`, `static ParamSpec<Params> spec()` and a constructor
/// from Params (io binds JSON to the spec, builds Params and constructs the object).
template <class T>
concept Parametrised = requires {
  typename T::Params;
  { T::spec() } -> std::convertible_to<ParamSpec<typename T::Params>>;
}
&&std::constructible_from<T, const typename T::Params&>;

/// A contact law (engine/contact/contact_model.hpp): its name, per-contact state columns, the
/// force of a contact, the stiffnesses and the Rayleigh step used by the stable step.
template <class L>
concept ContactLaw = Parametrised<L> &&
    requires(const L& law, const ContactGeometry& g, const RelativeMotion& m, double dt, double* state, double radius, double density) {
  { L::kName } -> std::convertible_to<std::string_view>;
  { L::state_columns() } -> std::convertible_to<std::vector<std::string>>;
  { law(g, m, dt, state) } -> std::same_as<ContactForces>;
  { law.normal_stiffness(g) } -> std::convertible_to<double>;
  { law.tangential_stiffness(g) } -> std::convertible_to<double>;
  { law.rayleigh_dt(radius, density) } -> std::convertible_to<double>;
};

/// A bond law (engine/contact/bond_model.hpp): its name, per-bond state columns, the forces and
/// torques of a bond and its stiffness for the stable step.
template <class L>
concept BondLaw = Parametrised<L> && requires(const L& law, const BondGeometry& g, const BondMotion& m, double dt, double* state) {
  { L::kName } -> std::convertible_to<std::string_view>;
  { L::state_columns() } -> std::convertible_to<std::vector<std::string>>;
  { law(g, m, dt, state) } -> std::same_as<BondForces>;
  { law.stiffness(g) } -> std::same_as<BondStiffness>;
};

/// A module (engine/model/module.hpp): a Module built from its parameters.
template <class M>
concept ModuleType = Parametrised<M> && std::derived_from<M, Module>;

/// A packing generator (engine/model/generator.hpp): a Generator built from its parameters that
/// names the walls it creates.
template <class G>
concept GeneratorType = Parametrised<G> && std::derived_from<G, Generator> && requires {
  { G::created_walls() } -> std::convertible_to<std::vector<std::string>>;
};

/// A monitor (engine/simulation.hpp) used as a stage key: a Monitor built from its parameters.
template <class M>
concept MonitorType = Parametrised<M> && std::derived_from<M, Monitor>;

}  // namespace sparkdem

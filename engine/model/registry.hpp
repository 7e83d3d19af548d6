#pragma once
/// The registry of named contact laws, bond laws, modules, generators and monitors. Filled once by
/// physics::register_all() (the single checked-in table); io binds JSON through the specs.
/// An unknown name is a ConfigError that lists every registered name.
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "engine/contact/bond_model.hpp"
#include "engine/contact/contact_model.hpp"
#include "engine/core/error.hpp"
#include "engine/model/contracts.hpp"
#include "engine/model/generator.hpp"
#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"

namespace sparkdem {

template <class T>
struct RegistryEntry {
  Spec spec;
  std::function<std::unique_ptr<T>(const ParamValues&)> make;
  std::vector<std::string> walls;  ///< generators: the walls it creates (G::created_walls()); else empty
};

class Registry {
 public:
  /// Register a contact law type (the ContactLaw concept, engine/model/contracts.hpp).
  template <ContactLaw Law>
  void contact_law() {
    auto ps = std::make_shared<ParamSpec<typename Law::Params>>(Law::spec());
    laws_[std::string(Law::kName)] = {
        ps->spec(),
        [ps](const ParamValues& v) -> std::unique_ptr<ContactModel> { return std::make_unique<ContactModelT<Law>>(ps->build(v)); },
        {}};
  }
  /// Register a bond law type (the BondLaw concept, engine/model/contracts.hpp).
  template <BondLaw Law>
  void bond_law() {
    auto ps = std::make_shared<ParamSpec<typename Law::Params>>(Law::spec());
    bond_laws_[std::string(Law::kName)] = {
        ps->spec(), [ps](const ParamValues& v) -> std::unique_ptr<BondModel> { return std::make_unique<BondModelT<Law>>(ps->build(v)); }, {}};
  }
  /// Register a module or generator M with `static ParamSpec<M::Params> spec()` and
  /// a constructor from M::Params.
  template <ModuleType M>
  void module() {
    auto ps = std::make_shared<ParamSpec<typename M::Params>>(M::spec());
    modules_[ps->spec().name] = {
        ps->spec(), [ps](const ParamValues& v) -> std::unique_ptr<Module> { return std::make_unique<M>(ps->build(v)); }, {}};
  }
  template <GeneratorType G>
  void generator() {
    auto ps = std::make_shared<ParamSpec<typename G::Params>>(G::spec());
    generators_[ps->spec().name] = {ps->spec(),
                                    [ps](const ParamValues& v) -> std::unique_ptr<Generator> { return std::make_unique<G>(ps->build(v)); },
                                    G::created_walls()};
  }

  /// Register a monitor M (a stage key named after its spec, e.g. "compact") with
  /// `static ParamSpec<M::Params> spec()` and a constructor from M::Params.
  template <MonitorType M>
  void monitor() {
    auto ps = std::make_shared<ParamSpec<typename M::Params>>(M::spec());
    monitors_[ps->spec().name] = {
        ps->spec(), [ps](const ParamValues& v) -> std::unique_ptr<Monitor> { return std::make_unique<M>(ps->build(v)); }, {}};
  }

  const std::map<std::string, RegistryEntry<ContactModel>>& laws() const { return laws_; }
  const std::map<std::string, RegistryEntry<BondModel>>& bond_laws() const { return bond_laws_; }
  const std::map<std::string, RegistryEntry<Module>>& modules() const { return modules_; }
  const std::map<std::string, RegistryEntry<Generator>>& generators() const { return generators_; }
  const std::map<std::string, RegistryEntry<Monitor>>& monitors() const { return monitors_; }

 private:
  std::map<std::string, RegistryEntry<ContactModel>> laws_;
  std::map<std::string, RegistryEntry<BondModel>> bond_laws_;
  std::map<std::string, RegistryEntry<Module>> modules_;
  std::map<std::string, RegistryEntry<Generator>> generators_;
  std::map<std::string, RegistryEntry<Monitor>> monitors_;
};

}  // namespace sparkdem

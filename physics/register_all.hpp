#pragma once
#include "engine/model/registry.hpp"
namespace sparkdem::physics {
/// Fill the registry with every law, module and generator (physics/register_all.cpp).
void register_all(Registry& r);
}  // namespace sparkdem::physics

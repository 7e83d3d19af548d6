#pragma once
/// Basic types shared by every layer. SI units throughout.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace sparkdem {

using Vec3 = Eigen::Vector3d;     ///< 3-vector [unit given by the quantity]
using Quat = Eigen::Quaterniond;  ///< unit quaternion (orientation)
using Index = std::int32_t;       ///< local particle index
using Id = std::int64_t;          ///< global particle id, stable across reorderings
using Step = std::int64_t;        ///< step counter; a fixed-step stage's time is step * dt, never accumulated (an adaptive one sums its steps)

}  // namespace sparkdem

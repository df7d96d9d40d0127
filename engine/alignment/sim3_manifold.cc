#include "engine/alignment/sim3_manifold.h"

#include <cmath>

namespace glam {

Sim3Parameters Sim3ToParameters(const Sim3& g) {
  const Eigen::Vector3d omega = g.rotation().Log();
  const Eigen::Vector3d& t = g.translation();
  return {t.x(), t.y(), t.z(), omega.x(), omega.y(), omega.z(), std::log(g.scale())};
}

Sim3 Sim3FromParameters(const double* parameters) {
  const Eigen::Map<const Vector7d> p(parameters);
  return Sim3(std::exp(p(6)), SO3::Exp(p.segment<3>(3)), p.head<3>());
}

Sim3PlusJacobian Sim3ParametersPlusJacobian(const double* parameters) {
  const Eigen::Map<const Vector7d> p(parameters);
  const Eigen::Vector3d t = p.head<3>();
  Sim3PlusJacobian J = Sim3PlusJacobian::Zero();
  J.block<3, 3>(0, 0).setIdentity();
  J.block<3, 3>(0, 3) = -Hat(t);
  J.block<3, 1>(0, 6) = t;
  J.block<3, 3>(3, 3) = SO3::LeftJacobianInverse(p.segment<3>(3));
  J(6, 6) = 1.0;
  return J;
}

Sim3PlusJacobian Sim3ParametersMinusJacobian(const double* parameters) {
  // Block inverse of P: [[I, Hat(t) Jl, -t], [0, Jl, 0], [0, 0, 1]].
  const Eigen::Map<const Vector7d> p(parameters);
  const Eigen::Vector3d t = p.head<3>();
  const Eigen::Matrix3d Jl = SO3::LeftJacobian(p.segment<3>(3));
  Sim3PlusJacobian J = Sim3PlusJacobian::Zero();
  J.block<3, 3>(0, 0).setIdentity();
  J.block<3, 3>(0, 3) = Hat(t) * Jl;
  J.block<3, 1>(0, 6) = -t;
  J.block<3, 3>(3, 3) = Jl;
  J(6, 6) = 1.0;
  return J;
}

bool Sim3Manifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const Sim3 g = Sim3::Exp(Eigen::Map<const Vector7d>(delta)) * Sim3FromParameters(x);
  const Sim3Parameters p = Sim3ToParameters(g);
  for (int i = 0; i < kSim3AmbientSize; ++i) x_plus_delta[i] = p[i];
  return true;
}

bool Sim3Manifold::PlusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Sim3PlusJacobian> out(jacobian);
  out = Sim3ParametersPlusJacobian(x);
  return true;
}

bool Sim3Manifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  const Sim3 y_from_x = Sim3FromParameters(y) * Sim3FromParameters(x).Inverse();
  Eigen::Map<Vector7d> out(y_minus_x);
  out = y_from_x.Log();
  return true;
}

bool Sim3Manifold::MinusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Sim3PlusJacobian> out(jacobian);
  out = Sim3ParametersMinusJacobian(x);
  return true;
}

}  // namespace glam

// The two factors of the submap graph (paper, "Global Submap Alignment"), with analytic
// Jacobians:
//   * SubmapPointFactor: r = (s_i R_i x_ij + t_i - X_j) / (s_i d_i), one per observation of a
//     landmark node X_j by submap i (x_ij = the landmark in submap i's frame, d_i = the
//     submap's median landmark depth in its own units). s_i d_i is the viewing depth in world
//     units at the CURRENT scale, so r is a fraction of depth whatever the submap's scale,
//     and the cost is invariant under a global Sim3 (submap_graph.h says why that matters).
//   * LogScalePriorFactor: r = lambda (sigma_i - sigma_i0), the paper's ||lambda mu_i||^2 on the
//     CHANGE of log-scale since insertion (monocular submaps start at arbitrary scales, so a
//     prior towards sigma = 0 would pull every submap towards the first one's units).
//
// How the Jacobians meet the manifold (see sim3_manifold.h). With left updates the
// project's convention (Sim3::ActionLeftJacobian) gives d(y)/d(delta) = [I, -Hat(y), y] for
// y = s R x + t, and d(s)/d(delta) = s e_sigma^T; the quotient rule then gives the tangent
// Jacobian
//   dr/d delta = ([I, -Hat(y), y] - (y - X) e_sigma^T) / (s d) = [I, -Hat(y), X] / (s d),
//   dr/dX = -I / (s d).
// Ceres asks for the Jacobian w.r.t. the AMBIENT storage [t, omega, sigma] and multiplies it
// by PlusJacobian P itself. We return the true ambient Jacobian (r = (R x + (t - X)/s) / d):
//   dr/d[t, omega, sigma] = [I / (s d), -Hat(R x) Jl(omega) / d, -(t - X) / (s d)]
//                         = (dr/d delta) * P^-1,
// so Ceres' product is exactly the tangent Jacobian above. Because it is the genuine
// derivative (no "[I; 0]" trick), numeric differentiation in the ambient space
// (GradientChecker) checks it, and so does differentiation through Plus in the tangent space.
#pragma once

#include <ceres/sized_cost_function.h>
#include <Eigen/Core>

namespace glam {

class SubmapPointFactor final : public ceres::SizedCostFunction<3, 7, 3> {
 public:
  // depth_in_submap_units: the submap's median landmark depth in its own units (> 0).
  SubmapPointFactor(const Eigen::Vector3d& point_in_submap, double depth_in_submap_units);

  // parameters[0]: Sim3 storage (sim3_manifold.h), parameters[1]: landmark in world.
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector3d point_in_submap_;
  double inverse_depth_;
};

class LogScalePriorFactor final : public ceres::SizedCostFunction<1, 7> {
 public:
  LogScalePriorFactor(double initial_log_scale, double weight);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  double initial_log_scale_;
  double weight_;
};

}  // namespace glam

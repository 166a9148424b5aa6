#pragma once
// Registration of two submap point clouds (geometry::PointCloud, each in its own submap frame).
// Both algorithms estimate T_target_source (source points mapped into the target frame) starting from
// the odometry estimate, and return a result struct instead of failing silently (STYLE 10).
//
//  - icpPointToPoint2d: the baseline of Teixeira et al. 2016 / thesis 4.2.1 (PCL 2D point-to-point):
//    only x, y and yaw change, z, roll and pitch stay at the initial value. Accept its result with
//    checkIcpAcceptance() (thesis Alg. 6 criteria 1-3).
//  - icpPointToPlane: Gauss-Newton point-to-plane ICP (Low 2004) on the 6-vector
//    x = (x, y, z, roll, pitch, yaw) of T_target_source (pose_vector.hpp), degeneracy-aware as thesis
//    Alg. 7 (Zhang et al. 2016, solution remapping): at every iteration A^T A (over the estimated
//    components) is eigen-decomposed and the step is taken only along well-conditioned eigenvectors.
//
// Well-conditioned rule (replaces the thesis's heuristic lambda_min, which thesis 5.2 leaves open):
// with point-to-plane residuals of standard deviation sigma_point_m, the Gauss-Newton estimate has
// covariance sigma^2 (A^T A)^-1, so along a unit eigenvector v_i (eigenvalue lambda_i) its standard
// deviation is sigma_point_m / sqrt(lambda_i). A direction is well-conditioned when that predicted
// standard deviation is at most max_direction_stddev, i.e. lambda_i >= (sigma_point_m /
// max_direction_stddev)^2. The eigenvectors mix metres and radians, so the bound reads as metres for
// translations and radians for rotations (1 rad ~ 1 m lever arm, the size of a submap's features).
// Note that the rule trusts the normals: noisy normals add spurious information along a wall, which
// grows with the point count, so sigma_point_m should not be set below the real residual noise.
//
// Noise floor (normal_noise_floor): a point whose step along v moves it by d contributes (n . d)^2 to
// v's information; where d runs along its surface that is (dn . d)^2, the normal's error dn, of mean
// sigma_n^2 |d - (n . d) n|^2. That mean, summed over the correspondences, is taken off v's eigenvalue
// before the rule, with sigma_n^2 (per tangent axis of one normal) a quarter of the mean of
// |n_target - n_source|^2 over the correspondences (two normals' noise on two axes). On a plain wall
// the slide then keeps almost nothing, while the normal and the heading (wall points moving across the
// wall) and a feature's sides (moving across their own surface) keep what they had.
//
// Unique optimum (the eigenvalue alone cannot tell): on a long flat wall with a few small features the
// normals' noise makes the slide along the wall look well-conditioned while a second optimum lies
// along it (a feature seen by one submap only, or none). So each direction the rule keeps is probed:
// the result is shifted along it by probe_steps steps up to probe_max_shift_m (the RMS displacement
// of the source points) both ways, the other kept directions settle (three Gauss-Newton steps within
// the final bound c), and the truncated point-to-plane cost of the result's correspondences
// (residuals capped at c, a lost correspondence costs c^2) must rise by at least
// min_probe_cost_points * c^2 at every shift: every shift must move that many correspondences off
// their surfaces. A direction that fails is dropped from V_u as degenerate. Points that gain a
// correspondence when shifted do not count, so a larger overlap never passes for a constraint, nor
// do points that slide along their surface (more along it than across) to where the target saw
// nothing (TargetKnown): past the end of what the target saw a shift tells nothing, while a point
// pushed through its surface counts. On a plain wall the shift along it then costs nothing.

#include "vog/geometry/point_cloud.hpp"
#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/slam/pose_vector.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <functional>
#include <numbers>
#include <string>

namespace vog::slam {

struct IcpResult {
  bool converged = false;
  int iterations = 0;
  // Mean squared distance between corresponding points at the result, and their number (point-to-
  // plane: within the final correspondence bound).
  double fitness_m2 = 0.0;
  std::size_t n_correspondences = 0;
  geometry::Pose3 T_target_source = geometry::Pose3::Identity();
  // A^T A / sigma^2 at the result over (x, y, z, roll, pitch, yaw); rows/columns of components that
  // were not estimated are zero.
  Matrix6d information = Matrix6d::Zero();
  // sigma^2 sum_u v_u v_u^T / lambda_u: the covariance restricted to the well-conditioned subspace
  // (zero along degenerate and non-estimated directions).
  Matrix6d covariance = Matrix6d::Zero();
  // Well-conditioned directions at the result, one orthonormal row per direction (k x 6), ordered
  // by decreasing eigenvalue; eigenvalues of A^T A for those rows.
  Eigen::MatrixXd V_u;
  Eigen::VectorXd eigenvalues_u;
  // All eigenvalues of A^T A over the estimated components, ascending.
  Eigen::VectorXd eigenvalues;
  // Directions the eigenvalue rule kept and the unique-optimum probe dropped (point-to-plane).
  int ambiguous_directions = 0;
};

struct PointToPoint2dConfig {
  int max_iterations = 50;
  double max_correspondence_distance_m = 1.0;
  // Converged when the step is below both (PCL transformation epsilon) ...
  double translation_epsilon_m = 1e-5;
  double rotation_epsilon_rad = 1e-5;
  // ... or the mean squared correspondence distance changes by less than this fraction (PCL
  // euclidean fitness epsilon). Reaching max_iterations is not convergence.
  double mse_relative_epsilon = 1e-8;
  double sigma_point_m = 0.1;  // for the information matrix only
  std::size_t min_points = 30;
  std::size_t min_correspondences = 20;

  Status validate() const;
};

Result<IcpResult> icpPointToPoint2d(const geometry::PointCloud& source, const geometry::PointCloud& target,
                                    const geometry::Pose3& T_target_source_init, const PointToPoint2dConfig& config);

enum class IcpDofs {
  kPlanar,  // x, y, yaw (the thesis's pose estimation problem, 4.2.1); z, roll, pitch held
  kFull,    // all six components
};

struct PointToPlaneConfig {
  int max_iterations = 30;
  // Correspondences are searched within max_correspondence_distance_m at the first iteration (the
  // capture range of the initial guess); the bound then shrinks by correspondence_shrink per
  // iteration down to min_correspondence_distance_m, and only there can the ICP converge. The
  // result's fitness and correspondence count are taken within the final bound. Two submaps of a
  // profiling sonar overlap only in part: with a fixed 1 m bound the points of the faces only one of
  // them saw pull the alignment towards them and dominate the fitness (on the pilings, vog-bench
  // mission: the 1 m fitness of registrations within 0.2 m of the truth, 0.04-0.28 m^2 (10-90 %),
  // overlapped that of the others, 0.07-0.36, and on the median a registration was no closer to the
  // truth than its initial guess; shrinking to 0.3 m, three voxels of the map, halved the error of
  // the rejected ones).
  // Equal bounds: a fixed bound.
  double max_correspondence_distance_m = 1.0;
  double min_correspondence_distance_m = 0.3;
  double correspondence_shrink = 0.7;
  double convergence_epsilon = 1e-6;  // norm of the step (m and rad)
  // Standard deviation of a point-to-plane residual: sonar range resolution and voxel size.
  double sigma_point_m = 0.1;
  // Well-conditioned rule above. Used only when degeneracy_aware. 3 cm: a profiling sonar's submap
  // of a propeller holds a few hundred cloud points, with which no translation reaches 1 cm
  // (vog-bench slam).
  double max_direction_stddev = 0.03;
  // Noise floor (degeneracy_aware only; the rule above): the information the normals' own noise adds
  // along a direction is taken off its eigenvalue before the rule. Needs the normals check on.
  bool normal_noise_floor = false;
  // Unique-optimum probe above (degeneracy_aware only): shifts of probe_max_shift_m / probe_steps,
  // 2 probe_max_shift_m / probe_steps, ... up to probe_max_shift_m on both sides (1 m: the capture
  // range, so the shortest shift is beyond the final bound); 0 steps turns the probe off, as it is by
  // default: on the missions of daemon/slam/README.md it halves the wrong closures on a hull but the
  // trajectory does not come out better (3 steps is the setting measured there).
  double probe_max_shift_m = 1.0;
  int probe_steps = 0;
  // 8 correspondences: with sigma_point_m 0.1 and a 0.3 m bound, 72 sigma^2 of cost, where the
  // voxel-sized residuals of a few thousand wall points vary by about 10 sigma^2 between shifts.
  double min_probe_cost_points = 8.0;
  // Normals agreement: a correspondence counts only when the source point's normal (turned by the
  // estimate) and the target point's are at most this far apart. Both clouds' normals point towards
  // the sonar that saw the surface, so the two faces of a thin plate or the near and far sides of a
  // piling do not pair up. Below pi the source must carry normals too; pi: no check. At 45 deg (with
  // the search below) the missions of daemon/slam/README.md end with a smaller trajectory error on every
  // scene than without the check. A grid read back from a mission folder orients its normals as it did
  // live (its sensor origins are in the journal), so a resumed mission continues as an uninterrupted one.
  double max_normal_angle_rad = std::numbers::pi / 4.0;
  // With the check on, a source point pairs with the nearest of its normal_search_neighbours nearest
  // target points whose normal agrees (1: the nearest only, dropped when it disagrees). Where the two
  // submaps' estimates are still apart, the nearest target point often lies on another face (a thin
  // blade's other side, the next surface of a curved part); refusing such points outright left a
  // propeller run's revisits without correspondences and its long loops unclosed (daemon/slam/README.md).
  int normal_search_neighbours = 8;
  // false: plain point-to-plane ICP, stepping along every direction that is not numerically
  // singular (the thesis's lambda_min = 0, Fig. 4.13c).
  bool degeneracy_aware = true;
  IcpDofs dofs = IcpDofs::kPlanar;
  std::size_t min_points = 30;
  std::size_t min_correspondences = 20;

  Status validate() const;
};

// Whether the target observed a point of its frame (its grid holds the voxel, free or occupied). The
// probe does not count points that slide along their surface to where the target saw nothing: past
// the end of what the target saw, a shift tells nothing. Empty: the target saw everything.
using TargetKnown = std::function<bool(const Eigen::Vector3d&)>;

// The target cloud must carry normals (unit, finite).
Result<IcpResult> icpPointToPlane(const geometry::PointCloud& source, const geometry::PointCloud& target,
                                  const geometry::Pose3& T_target_source_init, const PointToPlaneConfig& config,
                                  const TargetKnown& target_known = {});

// Thesis Alg. 6 acceptance criteria for a registration.
struct IcpAcceptanceConfig {
  double max_fitness_m2 = 0.05;  // criterion 2: mean squared correspondence distance
  // Criterion 3: odometry drift rates (variance per second) along x and y; the largest plausible
  // drift after dt seconds is sqrt(cov_x dt + cov_y dt) (thesis 4.2.1).
  double odometry_cov_x_m2_per_s = 1e-3;
  double odometry_cov_y_m2_per_s = 1e-3;

  Status validate() const;
};

struct IcpAcceptance {
  bool accepted = false;
  std::string reason;                       // why rejected (empty when accepted)
  double translation_disagreement_m = 0.0;  // |(x, y) of ICP - (x, y) of odometry|
  double drift_bound_m = 0.0;
};

// Criteria (1) converged, (2) fitness below max_fitness_m2, (3) the x-y disagreement with the odometry
// relative pose at most the drift bound for dt_s seconds between the two submaps.
IcpAcceptance checkIcpAcceptance(const IcpResult& result, const geometry::Pose3& T_target_source_odom, double dt_s,
                                 const IcpAcceptanceConfig& config);

}  // namespace vog::slam

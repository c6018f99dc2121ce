// SPDX-License-Identifier: Apache-2.0
#include "keypoint_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>

#include <ceres/ceres.h>

#include "keypoint_costs.h"
#include "limb_lift.h"
#include "mannequin_shape.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

using Clock = std::chrono::steady_clock;
using namespace keypoint_detail;
constexpr double PI = std::numbers::pi;
constexpr double SHAPE_LIMIT = 3.0; // |β_k| ≤ 3 σ: beyond that, not an adult body
constexpr double HIP_TRUST = 0.5;

// ---------------------------------------------------------------------------------------------
// The linear body model.

KeypointBodyModel::Points points_of(const BodyMeasurements& m) {
  // The girth calibration moves neither the joints nor the head and foot shapes read here
  // (mannequin_shape.h); skipping it makes the model's 9 builds ~5 s cheaper.
  const MannequinShape shape = MannequinShape::uncalibrated(m, RestPose::TPOSE);
  KeypointBodyModel::Points P = KeypointBodyModel::Points::Zero();
  P.topRows<JOINT_COUNT>() = shape.joints();
  auto J = [&](Joint j) -> Eigen::Vector3d { return shape.joints().row(idx(j)).transpose(); };
  auto set = [&](Landmark l, const Eigen::Vector3d& p) { P.row(idx(l)) = p.transpose(); };
  const Ellipsoid* head = nullptr;
  const Ellipsoid* foot[2] = {nullptr, nullptr};
  for (const Ellipsoid& e : shape.ellipsoids()) {
    if (e.joint == idx(Joint::HEAD)) head = &e;
    if (e.joint == idx(Joint::LEFT_FOOT)) foot[0] = &e;
    if (e.joint == idx(Joint::RIGHT_FOOT)) foot[1] = &e;
  }
  if (!head || !foot[0] || !foot[1]) throw Error("keypoint model", 0, "the mannequin has no head or foot shape");
  // Face landmarks on the head ellipsoid (radii rx, ry, rz): eyes a little above its centre
  // (eye height ≈ 93.6 % of stature), the nose tip 1 cm proud of the ellipsoid, ears at its sides.
  const Eigen::Vector3d c = head->centre, r = head->radii;
  set(Landmark::NOSE, c + Eigen::Vector3d(0, -0.26 * r.y(), 1.07 * r.z()));
  set(Landmark::LEFT_EYE, c + Eigen::Vector3d(0.41 * r.x(), 0.04 * r.y(), 0.87 * r.z()));
  set(Landmark::RIGHT_EYE, c + Eigen::Vector3d(-0.41 * r.x(), 0.04 * r.y(), 0.87 * r.z()));
  set(Landmark::LEFT_EAR, c + Eigen::Vector3d(r.x(), -0.09 * r.y(), -0.05 * r.z()));
  set(Landmark::RIGHT_EAR, c + Eigen::Vector3d(-r.x(), -0.09 * r.y(), -0.05 * r.z()));
  set(Landmark::HEAD_TOP, c + Eigen::Vector3d(0, r.y(), 0));
  set(Landmark::NECK_BASE, 0.5 * (J(Joint::LEFT_SHOULDER) + J(Joint::RIGHT_SHOULDER)));
  // Annotated hips: 3.5 % of stature below and 1 % wider than the hip joint centres.
  const double H = m.height;
  const Eigen::Vector3d hip_offset(0.010 * H, -0.035 * H, 0.0);
  set(Landmark::LEFT_HIP_SURFACE, J(Joint::LEFT_HIP) + hip_offset);
  set(Landmark::RIGHT_HIP_SURFACE, J(Joint::RIGHT_HIP) + Eigen::Vector3d(-hip_offset.x(), hip_offset.y(), 0));
  set(Landmark::MID_HIP,
      0.5 * (P.row(idx(Landmark::LEFT_HIP_SURFACE)) + P.row(idx(Landmark::RIGHT_HIP_SURFACE))).transpose());
  // Feet: the foot ellipsoid runs from the heel to the toes; the big toe is on the inner side.
  for (int side = 0; side < 2; ++side) {
    const Eigen::Vector3d fc = foot[side]->centre, fr = foot[side]->radii;
    const double inward = side == 0 ? -1.0 : 1.0; // towards the body's mid-line
    const Landmark toe = side == 0 ? Landmark::LEFT_BIG_TOE : Landmark::RIGHT_BIG_TOE;
    const Landmark small = side == 0 ? Landmark::LEFT_SMALL_TOE : Landmark::RIGHT_SMALL_TOE;
    const Landmark heel = side == 0 ? Landmark::LEFT_HEEL : Landmark::RIGHT_HEEL;
    set(toe, fc + Eigen::Vector3d(0.45 * inward * fr.x(), -0.3 * fr.y(), 0.92 * fr.z()));
    set(small, fc + Eigen::Vector3d(-0.65 * inward * fr.x(), -0.4 * fr.y(), 0.62 * fr.z()));
    set(heel, fc + Eigen::Vector3d(0, -0.3 * fr.y(), -0.95 * fr.z()));
  }
  return P;
}

KeypointBodyModel build_mannequin_model() {
  KeypointBodyModel model;
  model.mean = points_of(KeypointBodyModel::measurements({}));
  for (int k = 0; k < KEYPOINT_SHAPE_PARAMS; ++k) {
    KeypointShape plus{}, minus{};
    plus[static_cast<std::size_t>(k)] = 1.0;
    minus[static_cast<std::size_t>(k)] = -1.0;
    model.basis[static_cast<std::size_t>(k)] =
        0.5 * (points_of(KeypointBodyModel::measurements(plus)) - points_of(KeypointBodyModel::measurements(minus)));
  }
  for (int j = 0; j < JOINT_COUNT; ++j)
    model.joint[static_cast<std::size_t>(j)] = j;
  auto attach = [&](Landmark l, Joint j) { model.joint[static_cast<std::size_t>(idx(l))] = idx(j); };
  for (Landmark l : {Landmark::NOSE, Landmark::LEFT_EYE, Landmark::RIGHT_EYE, Landmark::LEFT_EAR, Landmark::RIGHT_EAR,
                     Landmark::HEAD_TOP})
    attach(l, Joint::HEAD);
  attach(Landmark::NECK_BASE, Joint::SPINE3);
  for (Landmark l : {Landmark::MID_HIP, Landmark::LEFT_HIP_SURFACE, Landmark::RIGHT_HIP_SURFACE})
    attach(l, Joint::PELVIS);
  attach(Landmark::LEFT_BIG_TOE, Joint::LEFT_FOOT);
  attach(Landmark::LEFT_SMALL_TOE, Joint::LEFT_FOOT);
  attach(Landmark::LEFT_HEEL, Joint::LEFT_ANKLE);
  attach(Landmark::RIGHT_BIG_TOE, Joint::RIGHT_FOOT);
  attach(Landmark::RIGHT_SMALL_TOE, Joint::RIGHT_FOOT);
  attach(Landmark::RIGHT_HEEL, Joint::RIGHT_ANKLE);
  model.trust.fill(1.0);
  for (Landmark l : {Landmark::MID_HIP, Landmark::LEFT_HIP_SURFACE, Landmark::RIGHT_HIP_SURFACE})
    model.trust[static_cast<std::size_t>(idx(l))] = HIP_TRUST;
  return model;
}

// ---------------------------------------------------------------------------------------------
// The objective's terms as Ceres cost functions, with the analytic derivatives of
// keypoint_costs.h. Each joint's axis-angle is its own parameter block and the terms are split
// where they depend on few joints (the keypoints by limb, the prior by term), so that the
// normal equations are assembled from small blocks: one dense block over every number spent
// ~60 % of a fit forming JᵀJ from ~176 × 79 mostly-zero rows.

struct State {
  std::array<double, 3> global{};
  std::array<double, BODY_POSE> body{};
  std::array<double, 3> trans{};
  KeypointShape beta{};
  double cost = 0;
};

// The parameter blocks of a state for a cost on `joints`: global, those joints' axis-angles
// (views into body), trans, beta.
std::vector<double*> blocks_of(State& s, const std::vector<int>& joints) {
  std::vector<double*> blocks = {s.global.data()};
  for (int j : joints)
    blocks.push_back(s.body.data() + 3 * (j - 1));
  blocks.push_back(s.trans.data());
  blocks.push_back(s.beta.data());
  return blocks;
}

// The limb (branch of the skeleton) a body point hangs from, for grouping keypoints: the first
// of hips, collars and neck above its joint, or the pelvis (the trunk) when none is.
int branch_of(const KeypointBodyModel& model, int point) {
  for (int j = model.joint[static_cast<std::size_t>(point)]; j > 0; j = joint_parent(j))
    if (j == idx(Joint::LEFT_HIP) || j == idx(Joint::RIGHT_HIP) || j == idx(Joint::LEFT_COLLAR) ||
        j == idx(Joint::RIGHT_COLLAR) || j == idx(Joint::NECK))
      return j;
  return 0;
}

// The reprojection error of some observations, one residual block, with parameter blocks
// global (3), the axis-angle (3) of each joint in `joints` (those that move the observed points;
// the others are read as 0, which does not move them), trans (3), beta (4).
class ReprojectionCost final : public ceres::CostFunction {
public:
  ReprojectionCost(const KeypointBodyModel& model, Observations obs, const PinholeCamera& cam, std::vector<int> joints)
      : m_model(model), m_obs(std::move(obs)), m_camera(cam), m_joints(std::move(joints)) {
    set_num_residuals(2 * static_cast<int>(m_obs.points.size()));
    std::vector<int32_t>& sizes = *mutable_parameter_block_sizes();
    sizes.assign(m_joints.size() + 3, 3);
    sizes.back() = KEYPOINT_SHAPE_PARAMS;
  }
  const std::vector<int>& joints() const { return m_joints; }

  bool Evaluate(double const* const* p, double* r, double** jacobians) const override {
    const std::size_t n = m_joints.size();
    std::array<double, BODY_POSE> body{};
    for (std::size_t c = 0; c < n; ++c)
      std::copy(p[1 + c], p[1 + c] + 3, body.begin() + 3 * (m_joints[c] - 1));
    bool need_body = false;
    for (std::size_t c = 0; jacobians && c < n; ++c)
      need_body = need_body || jacobians[1 + c];
    std::vector<double> body_jacobian(need_body ? static_cast<std::size_t>(num_residuals()) * BODY_POSE : 0);
    double* jac[4] = {jacobians ? jacobians[0] : nullptr, need_body ? body_jacobian.data() : nullptr,
                      jacobians ? jacobians[n + 1] : nullptr, jacobians ? jacobians[n + 2] : nullptr};
    reprojection(m_model, m_obs, m_camera, p[0], body.data(), p[n + 1], p[n + 2], r, jacobians ? jac : nullptr);
    for (std::size_t c = 0; need_body && c < n; ++c) {
      if (!jacobians[1 + c]) continue;
      for (int i = 0; i < num_residuals(); ++i)
        std::copy_n(
            &body_jacobian[static_cast<std::size_t>(i) * BODY_POSE + 3 * static_cast<std::size_t>(m_joints[c] - 1)], 3,
            jacobians[1 + c] + 3 * i);
    }
    return true;
  }

private:
  const KeypointBodyModel& m_model;
  Observations m_obs;
  PinholeCamera m_camera;
  std::vector<int> m_joints;
};

// One term of the pose prior (pose_prior_terms()) on its joints' parameter blocks.
class PosePriorCost final : public ceres::CostFunction {
public:
  PosePriorCost(std::size_t term, const std::array<double, BODY_POSE>& relaxed) : m_term(term), m_relaxed(relaxed) {
    const PosePriorTerm& t = pose_prior_terms().at(term);
    set_num_residuals(t.residuals);
    mutable_parameter_block_sizes()->assign(t.joints.size(), 3);
  }

  bool Evaluate(double const* const* p, double* r, double** jacobians) const override {
    const PosePriorTerm& t = pose_prior_terms()[m_term];
    std::array<double, BODY_POSE> body{};
    for (std::size_t c = 0; c < t.joints.size(); ++c)
      std::copy(p[c], p[c] + 3, body.begin() + 3 * (t.joints[c] - 1));
    bool any = false;
    for (std::size_t c = 0; jacobians && c < t.joints.size(); ++c)
      any = any || jacobians[c];
    const std::size_t cols = 3 * t.joints.size();
    std::vector<double> jac(any ? static_cast<std::size_t>(t.residuals) * cols : 0);
    pose_prior_term(m_term, body.data(), m_relaxed, r, any ? jac.data() : nullptr);
    for (std::size_t c = 0; any && c < t.joints.size(); ++c) {
      if (!jacobians[c]) continue;
      for (int i = 0; i < t.residuals; ++i)
        std::copy_n(&jac[static_cast<std::size_t>(i) * cols + 3 * c], 3, jacobians[c] + 3 * i);
    }
    return true;
  }

private:
  std::size_t m_term;
  std::array<double, BODY_POSE> m_relaxed; // the pose pulled toward (relaxed_pose_for())
};

// Adds the reprojection error of `obs` to `problem`, one residual block per limb.
void add_reprojection(ceres::Problem& problem, const KeypointBodyModel& model, const Observations& obs,
                      const PinholeCamera& cam, State& s) {
  std::array<Observations, JOINT_COUNT> groups;
  std::array<std::vector<int>, JOINT_COUNT> joints;
  for (std::size_t i = 0; i < obs.points.size(); ++i) {
    const int point = obs.points[i];
    const auto b = static_cast<std::size_t>(branch_of(model, point));
    groups[b].points.push_back(point);
    groups[b].pixels.push_back(obs.pixels[i]);
    groups[b].sqrt_weight.push_back(obs.sqrt_weight[i]);
    groups[b].sigma = obs.sigma;
    // The joints that move the point: its joint (unless the point is that joint) and those above.
    for (int j = model.joint[static_cast<std::size_t>(point)]; j > 0; j = joint_parent(j))
      if (j != point) joints[b].push_back(j);
  }
  for (std::size_t b = 0; b < groups.size(); ++b) {
    if (groups[b].points.empty()) continue;
    std::sort(joints[b].begin(), joints[b].end());
    joints[b].erase(std::unique(joints[b].begin(), joints[b].end()), joints[b].end());
    auto* cost = new ReprojectionCost(model, std::move(groups[b]), cam, joints[b]);
    problem.AddResidualBlock(cost, nullptr, blocks_of(s, cost->joints()));
  }
}

// Levenberg–Marquardt iterations for each depth hypothesis: enough to tell a better basin
// (stage 3 finishes the winner), a cap that keeps the fit within its time budget.
constexpr int FLIP_ITERATIONS = 15;
constexpr double SAME_HYPOTHESIS = 0.02; // m: a lifted limb this close to the fit's is the fit's own

// An elbow whose wrist keypoint was not detected is seen only through its upper arm, so its
// flexion is left to the prior: there the pull aims at a typical everyday flexion (~17°) rather
// than the near-straight relaxed pose, which is a visible arm's best guess (a bend would show in
// 2D) but leaves a hidden forearm pointing straight on. Measured on keypoint_fit_test's poses and
// held-out draws against 9° (the relaxed pose), 26° and 34°: larger values help more hidden
// forearms but straighter true ones lose more. Knees keep the relaxed flexion (a hidden-ankle
// flexion of 17° changed one pose, for the worse).
constexpr double HIDDEN_ELBOW_FLEXION = 0.30; // rad

// The relaxed pose of pose_mean() with each elbow whose wrist keypoint is missing pulled toward
// HIDDEN_ELBOW_FLEXION (`observed(point)`: whether body point `point` has a keypoint).
template <typename Observed> std::array<double, BODY_POSE> relaxed_pose_for(Observed&& observed) {
  std::array<double, BODY_POSE> mean = pose_mean().mean;
  auto at = [](Joint j, int axis) { return static_cast<std::size_t>(3 * (idx(j) - 1) + axis); };
  if (!observed(idx(Joint::LEFT_WRIST))) mean[at(Joint::LEFT_ELBOW, 1)] = -HIDDEN_ELBOW_FLEXION;
  if (!observed(idx(Joint::RIGHT_WRIST))) mean[at(Joint::RIGHT_ELBOW, 1)] = HIDDEN_ELBOW_FLEXION;
  return mean;
}

constexpr double SHAPE_WEIGHT = 3.0;   // px-equivalent per population σ
constexpr double DEPTH_WEIGHT = 200.0; // px-equivalent per metre of depth change in stage 1

struct ShapePrior {
  template <typename T> bool operator()(const T* beta, T* r) const {
    for (int k = 0; k < KEYPOINT_SHAPE_PARAMS; ++k)
      r[k] = T(SHAPE_WEIGHT) * beta[k];
    return true;
  }
};

struct DepthPrior {
  double z0;
  template <typename T> bool operator()(const T* trans, T* r) const {
    r[0] = T(DEPTH_WEIGHT) * (trans[2] - T(z0));
    return true;
  }
};

// ---------------------------------------------------------------------------------------------

ceres::Solver::Options solver_options(const KeypointFitOptions& o) {
  ceres::Solver::Options s;
  // Sparse normal equations: the limbs' keypoints and the prior's terms touch few joints each
  // (ReprojectionCost, PosePriorCost), so JᵀJ has ~1/15 of a dense one's products. Eigen's
  // sparse Cholesky is the fastest on ~80 numbers (SuiteSparse's is ~10 % slower, measured in
  // keypoint_fit_bench); a Ceres built without either falls back to the dense one.
  if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::EIGEN_SPARSE)) {
    s.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    s.sparse_linear_algebra_library_type = ceres::EIGEN_SPARSE;
  } else if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE)) {
    s.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    s.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  } else {
    s.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  }
  s.max_num_iterations = std::max(1, o.max_iterations);
  s.num_threads = std::clamp(o.threads, 1, 2);
  s.logging_type = ceres::SILENT;
  s.minimizer_progress_to_stdout = false;
  s.function_tolerance = 1e-7;
  return s;
}

Eigen::Vector3d to_vec(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

State state_of(const Pose& pose, const KeypointShape& beta) {
  State s;
  for (int a = 0; a < 3; ++a) {
    s.global[static_cast<std::size_t>(a)] = pose.axis_angle(0, a);
    s.trans[static_cast<std::size_t>(a)] = pose.translation[a];
  }
  for (int j = 1; j < JOINT_COUNT; ++j)
    for (int a = 0; a < 3; ++a)
      s.body[static_cast<std::size_t>(3 * (j - 1) + a)] = pose.axis_angle(j, a);
  s.beta = beta;
  return s;
}

Pose pose_of(const State& s) {
  Pose pose;
  pose.axis_angle.row(0) = to_vec(s.global).transpose();
  for (int j = 1; j < JOINT_COUNT; ++j)
    for (int a = 0; a < 3; ++a)
      pose.axis_angle(j, a) = s.body[static_cast<std::size_t>(3 * (j - 1) + a)];
  pose.translation = to_vec(s.trans);
  return pose;
}

// The pixel of body point `point` among the observations, or null.
const Eigen::Vector2d* observed_pixel(const Observations& obs, int point) {
  const auto it = std::find(obs.points.begin(), obs.points.end(), point);
  return it == obs.points.end() ? nullptr : &obs.pixels[static_cast<std::size_t>(it - obs.points.begin())];
}

// Unit direction (camera frame) of the ray from the camera's centre through pixel `px`.
Eigen::Vector3d camera_ray(const PinholeCamera& cam, const Eigen::Vector2d& px) {
  return Eigen::Vector3d((px.x() - cam.principal_point.x()) / cam.focal,
                         -(px.y() - cam.principal_point.y()) / cam.focal, -1.0)
      .normalized();
}

// Pose start for stage 2: each upper arm and thigh turned towards its keypoint, lifted from the
// image as if the bone lay in the plane of its joint, leaning towards the body's front by what
// the bone's length leaves over (foreshortening; a limb in front of the body is the common case).
// Without this, an arm raised overhead is reached from the relaxed start by swinging it through
// the front, a local minimum that the 2D keypoints cannot tell apart.
void lift_limbs(const KeypointBodyModel& model, const PinholeCamera& cam, const Observations& obs, State& s) {
  Pose pose;
  pose.axis_angle.row(0) = to_vec(s.global).transpose();
  for (int j = 1; j < JOINT_COUNT; ++j)
    for (int a = 0; a < 3; ++a)
      pose.axis_angle(j, a) = s.body[static_cast<std::size_t>(3 * (j - 1) + a)];
  pose.translation = to_vec(s.trans);
  const JointPositions rest = model.rest_joints(s.beta);
  const auto G = joint_world_transforms(rest, pose);
  const Eigen::Vector3d front = G[0].linear() * Eigen::Vector3d::UnitZ();
  for (const auto& [upper, lower] :
       {std::pair{Joint::LEFT_SHOULDER, Joint::LEFT_ELBOW}, std::pair{Joint::RIGHT_SHOULDER, Joint::RIGHT_ELBOW},
        std::pair{Joint::LEFT_HIP, Joint::LEFT_KNEE}, std::pair{Joint::RIGHT_HIP, Joint::RIGHT_KNEE}}) {
    const auto it = std::find(obs.points.begin(), obs.points.end(), idx(lower));
    if (it == obs.points.end()) continue;
    const Eigen::Vector2d px = obs.pixels[static_cast<std::size_t>(it - obs.points.begin())];
    const Eigen::Vector3d P = G[static_cast<std::size_t>(idx(upper))].translation();
    const double D = std::max(-P.z(), 0.1);
    Eigen::Vector3d d((px.x() - cam.principal_point.x()) * D / cam.focal - P.x(),
                      -(px.y() - cam.principal_point.y()) * D / cam.focal - P.y(), 0);
    const Eigen::Vector3d bone = (rest.row(idx(lower)) - rest.row(idx(upper))).transpose();
    const double L = bone.norm(), planar = d.norm();
    if (planar < 1e-6 || L < 1e-6) continue;
    if (planar < L) d.z() = (front.z() >= 0 ? 1.0 : -1.0) * std::sqrt(L * L - planar * planar);
    const Eigen::Matrix3d parent = G[static_cast<std::size_t>(joint_parent(idx(upper)))].linear();
    const Eigen::Quaterniond q =
        Eigen::Quaterniond::FromTwoVectors(bone.normalized(), parent.transpose() * d.normalized());
    const Eigen::Vector3d aa = matrix_to_axis_angle(q.toRotationMatrix());
    for (int a = 0; a < 3; ++a)
      s.body[static_cast<std::size_t>(3 * (idx(upper) - 1) + a)] = aa[a];
  }
}

int iterations_of(const ceres::Solver::Summary& s) { return s.num_successful_steps + s.num_unsuccessful_steps; }

double elapsed_ms(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// The observations of a fit and the first guesses that similar triangles give.
struct Setup {
  PinholeCamera camera;
  Observations all, torso;
  double depth = 0; // torso centre's distance from the camera (m)
  Eigen::Vector3d centre_cam, centre_rest, pelvis_rest;
};

Setup set_up(const KeypointBodyModel& model, const Keypoints& keypoints) {
  Setup su;
  su.camera.focal = keypoints.focal;
  su.camera.principal_point = 0.5 * keypoints.image_size;
  const PinholeCamera& cam = su.camera;
  Observations &all = su.all, &torso = su.torso;
  Eigen::Vector2d top_px = Eigen::Vector2d::Zero(), bottom_px = Eigen::Vector2d::Zero();
  Eigen::Vector3d top_rest = Eigen::Vector3d::Zero(), bottom_rest = Eigen::Vector3d::Zero();
  int n_top = 0, n_bottom = 0;
  for (const Keypoint2D& k : keypoints.points) {
    const auto p = static_cast<std::size_t>(k.point);
    all.points.push_back(k.point);
    all.pixels.push_back(k.pixel);
    all.sqrt_weight.push_back(std::sqrt(k.confidence * model.trust[p]));
    const bool shoulder = k.point == idx(Joint::LEFT_SHOULDER) || k.point == idx(Joint::RIGHT_SHOULDER);
    const bool hip = k.point == idx(Landmark::LEFT_HIP_SURFACE) || k.point == idx(Landmark::RIGHT_HIP_SURFACE) ||
                     k.point == idx(Joint::LEFT_HIP) || k.point == idx(Joint::RIGHT_HIP);
    if (shoulder || hip) {
      torso.points.push_back(k.point);
      torso.pixels.push_back(k.pixel);
      torso.sqrt_weight.push_back(std::sqrt(k.confidence));
      (shoulder ? top_px : bottom_px) += k.pixel;
      (shoulder ? top_rest : bottom_rest) += model.mean.row(k.point).transpose();
      ++(shoulder ? n_top : n_bottom);
    }
  }
  // Keypoints guarantees 3 of the 4 torso points; the guard keeps a hand-built input safe.
  if (n_top == 0 || n_bottom == 0)
    throw Error(keypoints.source, 0, "too few torso keypoints for a fit (need a shoulder and a hip)");
  top_px /= n_top;
  bottom_px /= n_bottom;
  top_rest /= n_top;
  bottom_rest /= n_bottom;

  // Similar triangles: the torso's length in pixels over its length in metres gives f / depth.
  const double torso_px = std::max((top_px - bottom_px).norm(), 1.0);
  // SMPLify's Geman–McClure scale is 100 px for its images; here it scales with the person: one
  // torso length, so limbs a torso length off still pull while outliers far beyond are damped.
  all.sigma = torso.sigma = torso_px;
  su.depth = cam.focal * (top_rest - bottom_rest).norm() / torso_px;
  const Eigen::Vector2d centre_px = 0.5 * (top_px + bottom_px);
  su.centre_cam = Eigen::Vector3d((centre_px.x() - cam.principal_point.x()) * su.depth / cam.focal,
                                  -(centre_px.y() - cam.principal_point.y()) * su.depth / cam.focal, -su.depth);
  su.centre_rest = 0.5 * (top_rest + bottom_rest);
  su.pelvis_rest = model.mean.row(0).transpose();
  return su;
}

} // namespace

// ---------------------------------------------------------------------------------------------

BodyMeasurements KeypointBodyModel::measurements(const KeypointShape& beta) {
  BodyMeasurements m;
  const double k = 1.0 + beta[0] * 0.07 / m.height;
  for (std::string_view n : BodyMeasurements::names())
    m[n] *= k;
  const double crotch = m.crotch_height, arm = m.arm_length;
  m.crotch_height += beta[1] * 0.025 * k;
  m.knee_height *= m.crotch_height / crotch;
  m.arm_length += beta[2] * 0.020 * k;
  m.forearm_length *= m.arm_length / arm;
  m.shoulder_width += beta[3] * 0.020 * k;
  return m;
}

KeypointBodyModel::Points KeypointBodyModel::rest_points(const KeypointShape& beta) const {
  Points P = mean;
  for (std::size_t k = 0; k < beta.size(); ++k)
    P += beta[k] * basis[k];
  return P;
}

JointPositions KeypointBodyModel::rest_joints(const KeypointShape& beta) const {
  return rest_points(beta).topRows<JOINT_COUNT>();
}

KeypointBodyModel::Points KeypointBodyModel::posed_points(const KeypointShape& beta, const Pose& pose) const {
  const Points rest = rest_points(beta);
  const JointPositions J = rest.topRows<JOINT_COUNT>();
  const auto G = joint_world_transforms(J, pose);
  Points out;
  for (int i = 0; i < BODY_POINT_COUNT; ++i) {
    const int a = joint[static_cast<std::size_t>(i)];
    out.row(i) = (G[static_cast<std::size_t>(a)] * (rest.row(i) - J.row(a)).transpose()).transpose();
  }
  return out;
}

const KeypointBodyModel& mannequin_keypoint_model() {
  static const KeypointBodyModel model = build_mannequin_model();
  return model;
}

Eigen::Vector2d PinholeCamera::project(const Eigen::Vector3d& p) const {
  const double depth = std::max(-p.z(), 1e-9);
  return {principal_point.x() + focal * p.x() / depth, principal_point.y() - focal * p.y() / depth};
}

KeypointFit fit_keypoints(const Keypoints& keypoints, const KeypointFitOptions& options) {
  const auto t_start = Clock::now();
  const KeypointBodyModel& model = mannequin_keypoint_model();
  const Setup su = set_up(model, keypoints);
  KeypointFit fit;
  fit.camera = su.camera;
  const PinholeCamera& cam = fit.camera;
  const ceres::Solver::Options solver = solver_options(options);
  const Observations &all = su.all, &torso = su.torso;
  const Eigen::Vector3d &centre_cam = su.centre_cam, &centre_rest = su.centre_rest, &pelvis_rest = su.pelvis_rest;

  State start;
  start.body = pose_mean().mean;
  if (options.initial_pose) {
    start = state_of(*options.initial_pose, options.initial_shape);
    fit.stages.push_back({"camera", 0, 0, 0});
  }

  // Stage 1: camera translation and global orientation on the torso, front- and back-facing.
  KeypointFitStage stage1{"camera", 0, 0, 0};
  auto t0 = Clock::now();
  State best;
  bool have_best = false;
  for (int facing = 0; facing < (options.initial_pose ? 0 : 2); ++facing) {
    State s = start;
    const Eigen::Matrix3d R0 = facing == 0 ? Eigen::Matrix3d::Identity() : axis_angle_to_matrix({0, PI, 0});
    const Eigen::Vector3d g = matrix_to_axis_angle(R0);
    s.global = {g.x(), g.y(), g.z()};
    // Root transform: X = R0 (P − J0) + J0 + t; put the torso centre at centre_cam.
    const Eigen::Vector3d t = centre_cam - R0 * (centre_rest - pelvis_rest) - pelvis_rest;
    s.trans = {t.x(), t.y(), t.z()};
    ceres::Problem problem;
    // Only the global orientation and translation vary; pose and shape are held.
    add_reprojection(problem, model, torso, cam, s);
    for (int j = 1; j < JOINT_COUNT; ++j)
      if (problem.HasParameterBlock(s.body.data() + 3 * (j - 1)))
        problem.SetParameterBlockConstant(s.body.data() + 3 * (j - 1));
    problem.SetParameterBlockConstant(s.beta.data());
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<DepthPrior, 1, 3>(new DepthPrior{t.z()}), nullptr,
                             s.trans.data());
    ceres::Solver::Summary summary;
    ceres::Solve(solver, &problem, &summary);
    stage1.iterations += iterations_of(summary);
    s.cost = summary.final_cost;
    if (!have_best || s.cost < best.cost) {
      best = s;
      have_best = true;
      fit.facing_away = facing == 1;
    }
  }
  if (!options.initial_pose) {
    stage1.ms = elapsed_ms(t0);
    stage1.cost = best.cost;
    fit.stages.push_back(stage1);
  } else {
    best = start;
  }

  // Stages 2 and 3 share one problem; the shape block is held constant in stage 2.
  const std::array<double, BODY_POSE> relaxed =
      relaxed_pose_for([&](int p) { return observed_pixel(all, p) != nullptr; });
  auto solve_full = [&](State& s, bool with_shape, int& iterations, int max_iterations = 0) {
    ceres::Problem problem;
    add_reprojection(problem, model, all, cam, s);
    for (std::size_t t = 0; t < pose_prior_terms().size(); ++t) {
      std::vector<double*> blocks;
      for (int j : pose_prior_terms()[t].joints)
        blocks.push_back(s.body.data() + 3 * (j - 1));
      problem.AddResidualBlock(new PosePriorCost(t, relaxed), nullptr, blocks);
    }
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<ShapePrior, KEYPOINT_SHAPE_PARAMS, KEYPOINT_SHAPE_PARAMS>(new ShapePrior),
        nullptr, s.beta.data());
    for (int k = 0; k < KEYPOINT_SHAPE_PARAMS; ++k) {
      problem.SetParameterLowerBound(s.beta.data(), k, -SHAPE_LIMIT);
      problem.SetParameterUpperBound(s.beta.data(), k, SHAPE_LIMIT);
    }
    if (!with_shape) problem.SetParameterBlockConstant(s.beta.data());
    ceres::Solver::Summary summary;
    ceres::Solver::Options capped = solver;
    if (max_iterations > 0) capped.max_num_iterations = std::min(solver.max_num_iterations, max_iterations);
    ceres::Solve(capped, &problem, &summary);
    iterations += iterations_of(summary);
    s.cost = summary.final_cost;
  };

  // Stage 2: pose. A turned torso's 2D keypoints look the same turned the other way (mirror
  // about the viewing axis); fit from both turns and keep the better.
  KeypointFitStage stage2{"pose", 0, 0, 0};
  t0 = Clock::now();
  std::vector<State> starts = {best};
  if (!options.initial_pose) {
    const Eigen::Matrix3d R = axis_angle_to_matrix(to_vec(best.global));
    const Eigen::Vector3d forward = R * Eigen::Vector3d::UnitZ();
    const double yaw = std::atan2(forward.x(), forward.z());
    if (std::abs(std::sin(yaw)) > std::sin(15.0 * PI / 180.0)) {
      State mirrored = best;
      const Eigen::Vector3d g = matrix_to_axis_angle(axis_angle_to_matrix({0, -2.0 * yaw, 0}) * R);
      mirrored.global = {g.x(), g.y(), g.z()};
      starts.push_back(mirrored);
    }
  }
  // Each turn from the relaxed pose and from the lifted limbs: the lifting guesses the sign of
  // each limb's depth, the relaxed start does not.
  for (std::size_t i = 0, n = options.initial_pose ? 0 : starts.size(); i < n; ++i) {
    State lifted = starts[i];
    lift_limbs(model, cam, all, lifted);
    starts.push_back(lifted);
  }
  State chosen;
  for (std::size_t i = 0; i < starts.size(); ++i) {
    solve_full(starts[i], false, stage2.iterations);
    if (i == 0 || starts[i].cost < chosen.cost) chosen = starts[i];
  }
  if (!options.initial_pose) {
    // Per-limb depth hypotheses: each limb lifted onto its keypoints' camera rays, the elbow or
    // knee nearer or farther than the shoulder or hip and the wrist or ankle nearer or farther
    // than that (limb_lift.h), re-solved, kept when the objective (priors included) prefers it.
    // A limb whose middle keypoint is missing is lifted through the middle joint's present
    // image instead (the solve then moves it freely); one whose end keypoint is missing keeps its
    // hinge.
    for (const HingeLimb& limb : hinge_limbs()) {
      const Eigen::Vector2d* end_px = observed_pixel(all, idx(limb.end));
      const Eigen::Vector2d* middle_px = observed_pixel(all, idx(limb.middle));
      if (!middle_px && !end_px) continue;
      const State base = chosen;
      const JointPositions rest = model.rest_joints(base.beta);
      const JointPositions base_joints = posed_joints(rest, pose_of(base));
      const Eigen::Vector3d middle_ray =
          middle_px ? camera_ray(cam, *middle_px) : base_joints.row(idx(limb.middle)).transpose().normalized();
      const std::optional<Eigen::Vector3d> end_ray = end_px ? std::optional(camera_ray(cam, *end_px)) : std::nullopt;
      for (LiftDepth middle_depth : {LiftDepth::NEAR, LiftDepth::FAR})
        for (LiftDepth end_depth : {LiftDepth::NEAR, LiftDepth::FAR}) {
          if (!end_px && end_depth == LiftDepth::FAR) continue;
          Pose pose = pose_of(base);
          lift_limb(rest, limb, middle_ray, middle_depth, end_ray, end_depth, pose);
          // The hypothesis the fit already holds (joints within 2 cm) is a local minimum: skip it.
          const JointPositions lifted = posed_joints(rest, pose);
          if ((lifted.row(idx(limb.middle)) - base_joints.row(idx(limb.middle))).norm() < SAME_HYPOTHESIS &&
              (lifted.row(idx(limb.end)) - base_joints.row(idx(limb.end))).norm() < SAME_HYPOTHESIS)
            continue;
          State s = state_of(pose, base.beta);
          solve_full(s, false, stage2.iterations, FLIP_ITERATIONS);
          if (s.cost < chosen.cost) chosen = s;
        }
    }
  }
  stage2.ms = elapsed_ms(t0);
  stage2.cost = chosen.cost;
  fit.stages.push_back(stage2);

  // Stage 3: shape and pose.
  if (options.fit_shape) {
    KeypointFitStage stage3{"shape+pose", 0, 0, 0};
    t0 = Clock::now();
    solve_full(chosen, true, stage3.iterations);
    stage3.ms = elapsed_ms(t0);
    stage3.cost = chosen.cost;
    fit.stages.push_back(stage3);
  }

  // Results.
  fit.shape = chosen.beta;
  fit.measurements = KeypointBodyModel::measurements(chosen.beta);
  fit.pose.axis_angle.row(0) = to_vec(chosen.global).transpose();
  for (int j = 1; j < JOINT_COUNT; ++j)
    for (int a = 0; a < 3; ++a)
      fit.pose.axis_angle(j, a) = chosen.body[static_cast<std::size_t>(3 * (j - 1) + a)];
  fit.pose.translation = to_vec(chosen.trans);
  fit.rest_joints = model.rest_joints(chosen.beta);
  fit.joints = posed_joints(fit.rest_joints, fit.pose);
  const KeypointBodyModel::Points posed = model.posed_points(chosen.beta, fit.pose);
  double sum = 0;
  for (const Keypoint2D& k : keypoints.points) {
    const Eigen::Vector2d px = cam.project(posed.row(k.point).transpose());
    fit.projected.push_back(px);
    sum += (px - k.pixel).norm();
  }
  fit.mean_reprojection_px = keypoints.points.empty() ? 0.0 : sum / static_cast<double>(keypoints.points.size());
  fit.total_ms = elapsed_ms(t_start);
  return fit;
}

double keypoint_fit_objective(const Keypoints& keypoints, const Pose& pose, const KeypointShape& shape) {
  const KeypointBodyModel& model = mannequin_keypoint_model();
  const Setup su = set_up(model, keypoints);
  std::array<double, 3> global{}, trans{};
  std::array<double, BODY_POSE> body{};
  for (int a = 0; a < 3; ++a) {
    global[static_cast<std::size_t>(a)] = pose.axis_angle(0, a);
    trans[static_cast<std::size_t>(a)] = pose.translation[a];
  }
  for (int j = 1; j < JOINT_COUNT; ++j)
    for (int a = 0; a < 3; ++a)
      body[static_cast<std::size_t>(3 * (j - 1) + a)] = pose.axis_angle(j, a);
  std::vector<double> r(2 * su.all.points.size());
  reprojection(model, su.all, su.camera, global.data(), body.data(), trans.data(), shape.data(), r.data(), nullptr);
  double sum = 0;
  for (double x : r)
    sum += x * x;
  r.assign(static_cast<std::size_t>(pose_prior_residual_count()), 0.0);
  const auto relaxed = relaxed_pose_for([&](int p) { return observed_pixel(su.all, p) != nullptr; });
  pose_prior(body.data(), relaxed, r.data(), nullptr);
  for (double x : r)
    sum += x * x;
  std::array<double, KEYPOINT_SHAPE_PARAMS> rs{};
  ShapePrior{}(shape.data(), rs.data());
  for (double x : rs)
    sum += x * x;
  return 0.5 * sum;
}

Pose pose_for_rest(const Pose& pose, RestPose rest) {
  if (rest != RestPose::APOSE) return pose;
  // The A-pose lowers each arm by 45° about ∓Z at the shoulder (mannequin_shape.h).
  constexpr double DROP = 45.0 * PI / 180.0;
  Pose out = pose;
  for (int side : {1, -1}) {
    const Eigen::Matrix3d D = axis_angle_to_matrix({0, 0, -side * DROP});
    const int shoulder = idx(side > 0 ? Joint::LEFT_SHOULDER : Joint::RIGHT_SHOULDER);
    // Shoulder: G' = G · D⁻¹ so that G' (D a) = G a for the arm's rest offsets a; below it,
    // R' = D R D⁻¹ keeps every lower joint's world rotation (times D⁻¹) in step.
    const Eigen::Matrix3d Rs = axis_angle_to_matrix(pose.axis_angle.row(shoulder).transpose());
    out.axis_angle.row(shoulder) = matrix_to_axis_angle(Rs * D.transpose()).transpose();
    for (int j : {shoulder + 2, shoulder + 4, shoulder + 6}) {
      const Eigen::Matrix3d R = axis_angle_to_matrix(pose.axis_angle.row(j).transpose());
      out.axis_angle.row(j) = matrix_to_axis_angle(D * R * D.transpose()).transpose();
    }
  }
  return out;
}

} // namespace vfit

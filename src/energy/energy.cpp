#include "sag_hand_tracker/energy/energy.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <type_traits>

#include "sag_hand_tracker/energy/projection.h"
#include "sag_hand_tracker/energy/visibility.h"

namespace sag_hand_tracker {

ForearmGaussians forearmGaussians(const EnergyParams& params, const Eigen::Vector3d& wrist,
                                  const Eigen::Vector3d& direction) {
  ForearmGaussians arm;
  if (params.forearm_gaussians <= 0) return arm;
  const double share = params.forearm_length / params.forearm_gaussians;
  const Eigen::Matrix3d along = direction * direction.transpose();
  arm.cov = (0.25 * share * share) * along +
            (params.forearm_sigma * params.forearm_sigma) * (Eigen::Matrix3d::Identity() - along);
  for (int i = 0; i < params.forearm_gaussians; ++i) {
    arm.means.push_back(wrist + (params.forearm_gap + (i + 0.5) * share) * direction);
  }
  return arm;
}
namespace {

void checkOcclusionDepthScale(double scale) {
  if (!(scale >= 0.0) || !std::isfinite(scale)) {
    throw InputError("energy: occlusion_depth_scale must be a finite number >= 0 (m), got " +
                     std::to_string(scale));
  }
}

// A model Gaussian projected into one camera, with the Jacobian of (mean_x, mean_y, cov_xx,
// cov_xy, cov_yy) with respect to (mu_c, unique Sigma_c) when a gradient is wanted.
struct ProjectionWithJacobian {
  ProjectedGaussian projected;
  ProjectionJacobian jacobian;
};

ProjectionWithJacobian projectInCamera(ProjectionMode mode, const Eigen::Vector3d& mean,
                                       const Eigen::Matrix3d& cov, const Eigen::Matrix3d& K,
                                       bool with_jacobian) {
  ProjectionWithJacobian result;
  ProjectionJacobian* jacobian = with_jacobian ? &result.jacobian : nullptr;
  result.projected = mode == ProjectionMode::kPerspective
                         ? projectPerspective(mean, cov, K, jacobian)
                         : projectScaledOrthographic(mean, cov, K, jacobian);
  return result;
}

// Per-thread buffers of evaluateImpl (PoseEnergy is shared by the threads of a search).
struct EvaluationScratch {
  std::vector<Eigen::Vector3d> g_mean;
  std::vector<Eigen::Matrix3d> g_cov;
  std::vector<ProjectionWithJacobian> projections;
  std::vector<OverlapTerm> overlap_terms;
  std::vector<OverlapRange> ranges;
  // In the pair kernels' precision (EnergyParams::float_pairs).
  std::tuple<std::vector<float>, std::vector<double>> weighted, active;
  std::vector<double> sums;
  std::vector<double> depths, visibility, d_visibility;  // EnergyParams::occlusion_depth_scale
  std::vector<char> valid;
  std::vector<ProjectedGradient> visibility_gradient;
  std::vector<Occlusion> occlusions;  // softVisibility's pairs, for the gradient
};

// E_qq: D_qq with d(c_q, c_q) = 1.
double selfOverlap(const ImageGaussian& g) { return M_PI * g.sigma * g.sigma; }

EvaluationScratch& evaluationScratch() {
  thread_local EvaluationScratch scratch;
  return scratch;
}

}  // namespace

PoseEnergy::PoseEnergy(const HandModel& model, const EnergyParams& params)
    : model_(model), params_(params), ancestor_dofs_(model.ancestorJointDofs()) {
  validateHandModel(model_);
  range_weights_.fill(params_.joint_range_weight);
  for (const int j : thumbJoints(model_)) range_weights_[j] = params_.thumb_range_weight;
  for (int pip = 0; pip < kNumJointDof; ++pip) {
    const std::string& name = model_.joints[pip].name;
    const size_t at = name.rfind("_pip_flex");
    if (at == std::string::npos || at + 9 != name.size()) continue;
    const int dip = model_.jointIndex(name.substr(0, at) + "_dip_flex");
    if (dip >= 0) pip_dip_pairs_.emplace_back(pip, dip);
  }
  // Neighbouring long fingers, index to pinky.
  const std::array<LongFingerJoints, kNumFingers - 1> fingers = longFingerJoints(model_);
  for (size_t f = 0; f + 1 < fingers.size(); ++f) {
    const int radial = fingers[f].mcp_abd, ulnar = fingers[f + 1].mcp_abd;
    if (radial >= 0 && ulnar >= 0) abduction_neighbours_.emplace_back(radial, ulnar);
  }
  for (const LongFingerJoints& finger : fingers) {
    if (finger.mcp_abd >= 0) long_finger_abductions_.push_back(finger.mcp_abd);
  }
  // Each bone's finger, from the model's fingertip Gaussians up to the palm (-1: the palm's).
  std::vector<int> finger_of_bone(model_.bones.size(), -1);
  for (int f = 0; f < kNumFingers; ++f) {
    const int tip = model_.fingertip_gaussians[f];
    for (int b = model_.gaussians[tip].bone; b > 0; b = model_.bones[b].parent) {
      finger_of_bone[b] = f;
    }
  }
  for (size_t p = 0; p < model_.gaussians.size(); ++p) {
    for (size_t q = 0; q < model_.gaussians.size(); ++q) {
      const int a = finger_of_bone[model_.gaussians[p].bone];
      const int b = finger_of_bone[model_.gaussians[q].bone];
      if (a >= 1 && b == a + 1) collision_pairs_.emplace_back(p, q);
    }
  }
  // Which Gaussian may hide which (EnergyParams::occlusion_depth_scale): not on one bone, nor on
  // a bone and its parent; the forearm's (after the hand's, bone -1 here) only the palm's children
  // and beyond.
  const size_t count = numGaussians();
  auto boneOf = [this](size_t p) {
    return p < model_.gaussians.size() ? model_.gaussians[p].bone : -1;
  };
  auto parentOf = [this](int bone) { return bone >= 0 ? model_.bones[bone].parent : 0; };
  occluding_pairs_.assign(count * count, 0);
  for (size_t p = 0; p < count; ++p) {
    for (size_t r = 0; r < count; ++r) {
      const int a = boneOf(p), b = boneOf(r);
      const bool one_surface = a == b || parentOf(a) == b || parentOf(b) == a;
      occluding_pairs_[p * count + r] = p != r && !one_surface ? 1 : 0;
    }
  }
  // The model's mean colour, each Gaussian weighted by its largest cross-section (the area it
  // covers in an image when seen broadside), as the image's foreground colours are by area.
  std::vector<Hsv> colours;
  std::vector<double> areas;
  for (const ModelGaussian& gaussian : model_.gaussians) {
    const Eigen::Vector3d variances =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(gaussian.cov, Eigen::EigenvaluesOnly)
            .eigenvalues();  // ascending
    colours.push_back(gaussian.hsv);
    areas.push_back(gaussian.weight * std::sqrt(std::max(variances[1] * variances[2], 0.0)));
  }
  model_mean_colour_ = meanColour(colours, areas);
  if (!(params_.max_colour_gain >= 1.0) || !std::isfinite(params_.max_colour_gain)) {
    throw InputError("energy: max_colour_gain must be a finite number >= 1, got " +
                     std::to_string(params_.max_colour_gain));
  }
  const bool forearm_ok = params_.forearm_gaussians >= 0 && params_.forearm_gaussians <= 64 &&
                          params_.forearm_length > 0.0 && std::isfinite(params_.forearm_length) &&
                          params_.forearm_gap >= 0.0 && std::isfinite(params_.forearm_gap) &&
                          params_.forearm_sigma > 0.0 && std::isfinite(params_.forearm_sigma) &&
                          params_.forearm_weight >= 0.0 && std::isfinite(params_.forearm_weight);
  if (params_.forearm_gaussians != 0 && !forearm_ok) {
    throw InputError(
        "energy: the forearm needs 0..64 Gaussians, a finite length and sigma > 0, a finite gap "
        "and weight >= 0; got " +
        std::to_string(params_.forearm_gaussians) + " Gaussians, length " +
        std::to_string(params_.forearm_length) + ", gap " + std::to_string(params_.forearm_gap) +
        ", sigma " + std::to_string(params_.forearm_sigma) + ", weight " +
        std::to_string(params_.forearm_weight));
  }
  if (!(params_.saturation_softness >= 0.0 && params_.saturation_softness <= 1.0)) {
    throw InputError("energy: saturation_softness must be in [0, 1], got " +
                     std::to_string(params_.saturation_softness));
  }
  if (!(params_.model_area_weight >= 0.0) || !std::isfinite(params_.model_area_weight)) {
    throw InputError("energy: model_area_weight must be a finite number >= 0, got " +
                     std::to_string(params_.model_area_weight));
  }
  if (!(params_.wrist_weight >= 0.0 && std::isfinite(params_.wrist_weight) &&
        params_.wrist_tolerance >= 0.0 && std::isfinite(params_.wrist_tolerance) &&
        params_.wrist_scale > 0.0 && std::isfinite(params_.wrist_scale))) {
    throw InputError(
        "energy: the wrist prior needs a finite weight >= 0, tolerance >= 0 (m) and scale > 0 "
        "(m); got weight " +
        std::to_string(params_.wrist_weight) + ", tolerance " +
        std::to_string(params_.wrist_tolerance) + ", scale " + std::to_string(params_.wrist_scale));
  }
  checkOcclusionDepthScale(params_.occlusion_depth_scale);
}

double PoseEnergy::modelWeight(size_t p) const {
  if (p >= model_.gaussians.size()) return params_.forearm_weight * params_.model_weight;
  return model_.gaussians[p].weight * params_.model_weight;
}

size_t PoseEnergy::numGaussians() const {
  return model_.gaussians.size() + static_cast<size_t>(params_.forearm_gaussians);
}

void PoseEnergy::setModelAreaWeight(double weight) {
  if (!(weight >= 0.0) || !std::isfinite(weight)) {
    throw InputError("energy: model_area_weight must be a finite number >= 0, got " +
                     std::to_string(weight));
  }
  params_.model_area_weight = weight;
}

void PoseEnergy::setOcclusionDepthScale(double scale) {
  checkOcclusionDepthScale(scale);
  params_.occlusion_depth_scale = scale;
}

void PoseEnergy::setForearmDirection(const std::optional<Eigen::Vector3d>& direction) {
  forearm_direction_.reset();
  if (direction && direction->allFinite() && direction->norm() > 1e-9) {
    forearm_direction_ = direction->normalized();
  }
}

Eigen::Vector3d PoseEnergy::forearmDirectionFor(const Pose& pose) const {
  return forearm_direction_ ? *forearm_direction_ : Eigen::Vector3d(-pose.rotation.col(0));
}

double PoseEnergy::evaluateWithForearm(const Pose& pose,
                                       const Eigen::Vector3d& forearm_direction) const {
  if (!forearm_direction.allFinite() || !(forearm_direction.norm() > 1e-9)) {
    return evaluateImpl(pose, true, std::nullopt, nullptr, nullptr);
  }
  return evaluateImpl(pose, true, Eigen::Vector3d(forearm_direction.normalized()), nullptr,
                      nullptr);
}

bool isInFrontOfCameras(const Eigen::Vector3d& point,
                        const std::vector<CameraObservation>& observations, double min_depth) {
  for (const CameraObservation& observation : observations) {
    if (!((observation.camera.world_to_camera * point).z() >= min_depth)) return false;
  }
  return true;
}

void PoseEnergy::setFrame(const std::vector<CameraObservation>& observations) {
  cameras_.clear();
  wrist_rays_.clear();
  const size_t num_gaussians = numGaussians();
  std::vector<std::vector<const ImageGaussian*>> kept_per_camera;
  std::vector<Hsv> foreground_colours;
  std::vector<double> foreground_areas;
  for (const CameraObservation& observation : observations) {
    validateCamera(observation.camera);
    FrameCamera camera;
    camera.rotation = observation.camera.world_to_camera.linear();
    camera.translation = observation.camera.world_to_camera.translation();
    camera.K = observation.camera.K;
    const ImageSoG& sog = observation.sog;
    if (params_.wrist_weight > 0.0 && sog.arm_cells >= std::max(params_.wrist_min_cells, 1) &&
        sog.arm_centroid.allFinite()) {
      wrist_rays_.push_back(pixelRay(observation.camera, sog.arm_centroid));
    }
    std::vector<const ImageGaussian*> kept;
    double self_overlap_sum = 0.0;
    for (const ImageGaussian& g : observation.sog.gaussians) {
      if (g.mean.allFinite() && g.sigma > 0.0 && std::isfinite(g.sigma) && g.hsv.allFinite()) {
        kept.push_back(&g);
      }
    }
    // Sorted by x: overlapRange.
    std::stable_sort(kept.begin(), kept.end(), [](const ImageGaussian* a, const ImageGaussian* b) {
      return a->mean.x() < b->mean.x();
    });
    for (const ImageGaussian* g : kept) {
      const double self_overlap = selfOverlap(*g);
      self_overlap_sum += self_overlap;
      foreground_colours.push_back(g->hsv);
      foreground_areas.push_back(self_overlap);
    }
    // A camera that sees nothing carries no information: it is left out of the mean.
    if (kept.empty()) continue;
    camera.image_area = self_overlap_sum;
    cameras_.push_back(std::move(camera));
    kept_per_camera.push_back(std::move(kept));
  }
  const ColourCast cast =
      params_.correct_colour_cast
          ? colourCast(model_mean_colour_, meanColour(foreground_colours, foreground_areas),
                       params_.max_colour_gain)
          : ColourCast();
  for (size_t c = 0; c < cameras_.size(); ++c) {
    const std::vector<const ImageGaussian*>& kept = kept_per_camera[c];
    std::vector<Hsv> corrected;
    corrected.reserve(kept.size());
    for (const ImageGaussian* g : kept) corrected.push_back(cast.apply(g->hsv));
    // The pair kernels' inputs, in their precision (EnergyParams::float_pairs).
    auto fill = [&](auto& pairs) {
      auto& q = pairs.image_gaussians;
      using T = typename std::decay_t<decltype(q.mean_x)>::value_type;
      for (const ImageGaussian* g : kept) {
        q.mean_x.push_back(static_cast<T>(g->mean.x()));
        q.mean_y.push_back(static_cast<T>(g->mean.y()));
        q.variance.push_back(static_cast<T>(g->sigma * g->sigma));
        q.max_variance = std::max(q.max_variance, static_cast<double>(q.variance.back()));
        q.self_overlap.push_back(selfOverlap(*g));
      }
      pairs.weights.resize(num_gaussians * kept.size());
      for (size_t p = 0; p < num_gaussians; ++p) {
        const double model_weight = modelWeight(p);
        for (size_t i = 0; i < kept.size(); ++i) {
          // The forearm's Gaussians have the model's mean colour.
          const Hsv& colour =
              p < model_.gaussians.size() ? model_.gaussians[p].hsv : model_mean_colour_;
          pairs.weights[p * kept.size() + i] =
              static_cast<T>(model_weight * colourSimilarity(colour, corrected[i], params_.colour));
        }
      }
    };
    if (params_.float_pairs) {
      fill(std::get<PairInputs<float>>(cameras_[c].pairs));
    } else {
      fill(std::get<PairInputs<double>>(cameras_[c].pairs));
    }
  }
}

double PoseEnergy::evaluate(const Pose& pose, PoseVector* gradient, EnergyTerms* terms) const {
  return evaluateImpl(pose, forearm_present_, forearm_direction_, gradient, terms);
}

double PoseEnergy::evaluateImpl(const Pose& pose, bool with_forearm,
                                const std::optional<Eigen::Vector3d>& forearm_direction,
                                PoseVector* gradient, EnergyTerms* terms) const {
  return params_.float_pairs
             ? evaluateIn<float>(pose, with_forearm, forearm_direction, gradient, terms)
             : evaluateIn<double>(pose, with_forearm, forearm_direction, gradient, terms);
}

template <typename T>
double PoseEnergy::evaluateIn(const Pose& pose, bool with_forearm,
                              const std::optional<Eigen::Vector3d>& forearm_direction,
                              PoseVector* gradient, EnergyTerms* terms) const {
  PosedHand hand = forwardKinematics(model_, pose);
  const size_t num_hand_gaussians = hand.gaussians.size();
  // The forearm's Gaussians (EnergyParams::forearm_gaussians) after the hand's.
  if (with_forearm && params_.forearm_gaussians > 0) {
    const Eigen::Vector3d direction =
        forearm_direction ? *forearm_direction : Eigen::Vector3d(-pose.rotation.col(0));
    const ForearmGaussians arm = forearmGaussians(params_, pose.translation, direction);
    for (const Eigen::Vector3d& mean : arm.means) hand.gaussians.push_back({mean, arm.cov});
  }
  const size_t num_gaussians = hand.gaussians.size();
  const bool with_gradient = gradient != nullptr;

  // Gradient of E_sim with respect to each Gaussian's world mean and covariance (symmetric
  // full-matrix form: dE = g_mean . d_mean + tr(G_cov d_cov)).
  // The buffers of this thread's previous evaluation, reused: allocating them per evaluation
  // (about 100 kB for `weighted`) made glibc grow and trim the heap every time, and the page
  // faults and TLB flushes took 13 % of a tracking step on this VM.
  EvaluationScratch& scratch = evaluationScratch();
  std::vector<Eigen::Vector3d>& g_mean = scratch.g_mean;
  std::vector<Eigen::Matrix3d>& g_cov = scratch.g_cov;
  std::vector<ProjectionWithJacobian>& projections = scratch.projections;
  std::vector<OverlapTerm>& overlap_terms = scratch.overlap_terms;
  std::vector<OverlapRange>& ranges = scratch.ranges;
  std::vector<T>& weighted = std::get<std::vector<T>>(scratch.weighted);
  std::vector<T>& active = std::get<std::vector<T>>(scratch.active);
  std::vector<double>& sums = scratch.sums;
  g_mean.assign(num_gaussians, Eigen::Vector3d::Zero());
  g_cov.assign(num_gaussians, Eigen::Matrix3d::Zero());
  projections.resize(num_gaussians);  // each assigned per camera before it is read
  overlap_terms.resize(num_gaussians);
  ranges.resize(num_gaussians);

  double similarity = 0.0;
  if (terms) {
    terms->per_camera.assign(cameras_.size(), 0.0);
    terms->invalid_projections = 0;
  }
  const double lambda = params_.model_area_weight;
  double weight_sum = 0.0;
  for (size_t p = 0; p < num_gaussians; ++p) weight_sum += modelWeight(p);
  // EnergyParams::occlusion_depth_scale: each model Gaussian counts, in the overlap and in M_c,
  // with the share v_p of it a camera sees past the model Gaussians in front of it.
  const bool occluding = params_.occlusion_depth_scale > 0.0;
  std::vector<double>& depths = scratch.depths;
  std::vector<char>& valid = scratch.valid;
  std::vector<double>& visibility = scratch.visibility;
  std::vector<double>& d_visibility = scratch.d_visibility;
  std::vector<ProjectedGradient>& visibility_gradient = scratch.visibility_gradient;
  depths.assign(num_gaussians, 0.0);
  valid.assign(num_gaussians, 0);
  visibility.assign(num_gaussians, 1.0);
  const VisibilityInputs visibility_inputs{&overlap_terms,
                                           &depths,
                                           &valid,
                                           &occluding_pairs_,
                                           numGaussians(),
                                           params_.occlusion_depth_scale,
                                           params_.max_mahalanobis_sq};
  for (size_t c = 0; c < cameras_.size(); ++c) {
    const FrameCamera& camera = cameras_[c];
    const PairInputs<T>& pairs = std::get<PairInputs<T>>(camera.pairs);
    const ImageGaussianArraysOf<T>& q = pairs.image_gaussians;
    const int n = q.size();
    weighted.resize(num_gaussians * n);  // row p is written (and read) in ranges[p] only
    sums.assign(n, 0.0);
    double model_area = 0.0;  // M_c
    for (size_t p = 0; p < num_gaussians; ++p) {
      const Eigen::Vector3d mean = camera.rotation * hand.gaussians[p].mean + camera.translation;
      const Eigen::Matrix3d cov =
          camera.rotation * hand.gaussians[p].cov * camera.rotation.transpose();
      projections[p] = projectInCamera(model_.projection, mean, cov, camera.K, with_gradient);
      depths[p] = mean.z();
      valid[p] = projections[p].projected.valid ? 1 : 0;
      if (!projections[p].projected.valid) {
        // It cannot be seen where the camera sees foreground: a fixed share of the image's area
        // against the pose (no gradient; the optimizer's step control and the start's scoring
        // still see the lower value).
        model_area += weight_sum > 0.0 ? modelWeight(p) / weight_sum * camera.image_area : 0.0;
        if (terms) ++terms->invalid_projections;
        continue;
      }
      overlap_terms[p] = prepareOverlapTerm(projections[p].projected);
      // Only the image Gaussians within reach: the others' D_pq is 0.
      const OverlapRange range = ranges[p] =
          overlapRange(overlap_terms[p], q, params_.max_mahalanobis_sq);
      overlapRow(overlap_terms[p], q, range, pairs.weights.data() + p * n,
                 params_.max_mahalanobis_sq, weighted.data() + p * n);
    }
    if (occluding) {
      softVisibility(visibility_inputs, &visibility, with_gradient ? &scratch.occlusions : nullptr);
    }
    for (size_t p = 0; p < num_gaussians; ++p) {
      if (!valid[p]) continue;
      T* row = weighted.data() + p * n;
      if (occluding) {
        const T v = static_cast<T>(visibility[p]);
        for (int i = ranges[p].begin; i < ranges[p].end; ++i) row[i] *= v;
      }
      for (int i = ranges[p].begin; i < ranges[p].end; ++i) sums[i] += row[i];
      // M_c, only where it counts (lambda > 0): the integral of the projected Gaussian.
      if (lambda > 0.0) {
        model_area += modelWeight(p) * 2.0 * M_PI * overlap_terms[p].sqrt_det * visibility[p];
      }
    }

    // Paper eq. 8: sum over image Gaussians of min(sum_p w_p E_pq, E_qq). A saturated image
    // Gaussian passes no gradient.
    double overlap = 0.0;  // O_c
    active.resize(n);
    const double softness = params_.saturation_softness;
    for (int i = 0; i < n; ++i) {
      const bool saturated = sums[i] >= q.self_overlap[i];
      overlap += saturated ? q.self_overlap[i] : sums[i];
      active[i] = saturated ? T(0) : T(1);
    }
    if (softness > 0.0) {
      // EnergyParams::saturation_softness: a blend with E_qq (1 - exp(-S_q / E_qq)).
      overlap =
          (1.0 - softness) * overlap + softSaturation(q, sums.data(), softness, active.data());
    }
    // E_c = (1 + lambda) O_c / (I_c + lambda M_c): dE_c = a dO_c + b dM_c.
    const double denominator = camera.image_area + lambda * model_area;
    const double camera_similarity = (1.0 + lambda) * overlap / denominator;
    const double d_overlap = (1.0 + lambda) / denominator;
    const double d_area = -lambda * camera_similarity / denominator;
    similarity += camera_similarity;
    if (terms) terms->per_camera[c] = camera_similarity;
    if (!with_gradient) continue;

    if (occluding) {
      // dE_c/dv_p = a sum_q f'(S_q) w_pq E_pq + b w_p A_p, then through v_p to every Gaussian.
      d_visibility.assign(num_gaussians, 0.0);
      for (size_t p = 0; p < num_gaussians; ++p) {
        if (!valid[p] || !(visibility[p] > 0.0)) continue;
        const T* row = weighted.data() + p * n;
        double credited = 0.0;
        for (int i = ranges[p].begin; i < ranges[p].end; ++i) credited += active[i] * row[i];
        d_visibility[p] = d_overlap * credited / visibility[p] +
                          d_area * modelWeight(p) * 2.0 * M_PI * overlap_terms[p].sqrt_det;
      }
      visibility_gradient.assign(num_gaussians, ProjectedGradient::Zero());
      accumulateVisibilityGradient(visibility_inputs, visibility, scratch.occlusions, d_visibility,
                                   &visibility_gradient);
    }

    // Accumulate dE/d(mu_p, Sigma_p) over all image Gaussians, then chain once per (Gaussian,
    // camera) through the projection (its exact Jacobian) and the camera rotation.
    for (size_t p = 0; p < num_gaussians; ++p) {
      if (!valid[p]) continue;
      Eigen::Matrix<double, 5, 1> g_projected = Eigen::Matrix<double, 5, 1>::Zero();
      accumulateOverlapGradient(overlap_terms[p], q, ranges[p], weighted.data() + p * n,
                                active.data(), g_projected.data());
      g_projected *= d_overlap;
      if (d_area != 0.0) {
        // d(2 pi sqrt|S|) over (S_xx, S_xy as one entry, S_yy) = area/2 (S^-1)_xx, area (S^-1)_xy,
        // area/2 (S^-1)_yy.
        const OverlapTerm& t = overlap_terms[p];
        const double scale = d_area * modelWeight(p) * 2.0 * M_PI * t.sqrt_det * visibility[p];
        g_projected[2] += scale * 0.5 * t.inv_xx;
        g_projected[3] += scale * t.inv_xy;
        g_projected[4] += scale * 0.5 * t.inv_yy;
      }
      if (occluding) g_projected += visibility_gradient[p].head<5>();
      const Eigen::Matrix<double, 9, 1> g_input = projections[p].jacobian.transpose() * g_projected;
      Eigen::Vector3d g_mean_camera = g_input.head<3>();
      if (occluding) g_mean_camera.z() += visibility_gradient[p][5];  // the depth order
      Eigen::Matrix3d g_cov_camera;
      g_cov_camera << g_input[3], 0.5 * g_input[6], 0.5 * g_input[7],  //
          0.5 * g_input[6], g_input[4], 0.5 * g_input[8],              //
          0.5 * g_input[7], 0.5 * g_input[8], g_input[5];
      g_mean[p] += camera.rotation.transpose() * g_mean_camera;
      g_cov[p] += camera.rotation.transpose() * g_cov_camera * camera.rotation;
    }
  }

  const double camera_count = cameras_.empty() ? 1.0 : static_cast<double>(cameras_.size());
  similarity /= camera_count;
  PoseVector limit_gradient;
  const double penalty = limitPenalty(model_, pose, with_gradient ? &limit_gradient : nullptr);
  // PIP-DIP coupling prior (EnergyParams::dip_pip_coupling_weight).
  double coupling = 0.0;
  PoseVector coupling_gradient = PoseVector::Zero();
  if (params_.dip_pip_coupling_weight > 0.0) {
    for (const auto& [pip, dip] : pip_dip_pairs_) {
      const double residual = pose.joints[dip] - params_.dip_pip_ratio * pose.joints[pip];
      coupling += residual * residual;
      coupling_gradient[kFirstJointDof + dip] += 2.0 * residual;
      coupling_gradient[kFirstJointDof + pip] -= 2.0 * params_.dip_pip_ratio * residual;
    }
  }
  // Finger order prior (EnergyParams::finger_order_weight).
  double order = 0.0;
  PoseVector order_gradient = PoseVector::Zero();
  if (params_.finger_order_weight > 0.0) {
    for (const auto& [radial, ulnar] : abduction_neighbours_) {
      const double crossing =
          pose.joints[ulnar] - pose.joints[radial] - params_.finger_order_margin;
      if (!(crossing > 0.0)) continue;
      order += crossing * crossing;
      order_gradient[kFirstJointDof + ulnar] += 2.0 * crossing;
      order_gradient[kFirstJointDof + radial] -= 2.0 * crossing;
    }
  }
  // Fan-turn prior (EnergyParams::fan_turn_weight).
  double fan_turn = 0.0;
  PoseVector fan_turn_gradient = PoseVector::Zero();
  if (params_.fan_turn_weight > 0.0 && !long_finger_abductions_.empty()) {
    const double count = static_cast<double>(long_finger_abductions_.size());
    double common = 0.0;
    for (const int j : long_finger_abductions_) common += pose.joints[j];
    common /= count;
    const double excess = std::fabs(common) - params_.fan_turn_margin;
    if (excess > 0.0) {
      fan_turn = excess * excess;
      const double d_common = 2.0 * excess * (common > 0.0 ? 1.0 : -1.0) / count;
      for (const int j : long_finger_abductions_) fan_turn_gradient[kFirstJointDof + j] = d_common;
    }
  }
  // Finger collision prior (EnergyParams::finger_collision_weight): dF/dmu_p = -2 h f x,
  // dF/dSigma_p = dF/dSigma_q = h f x x^T with x = (Sigma_p + Sigma_q)^-1 d, h = f - f_0.
  double collision = 0.0;
  if (params_.finger_collision_weight > 0.0) {
    const double scale = -params_.finger_collision_weight * camera_count;
    for (const auto& [p, q] : collision_pairs_) {
      const Eigen::Vector3d d = hand.gaussians[p].mean - hand.gaussians[q].mean;
      const Eigen::Matrix3d sum = hand.gaussians[p].cov + hand.gaussians[q].cov;
      const Eigen::Vector3d x = sum.ldlt().solve(d);
      const double f = std::exp(-0.5 * d.dot(x));
      const double h = f - params_.finger_collision_threshold;
      if (!(h > 0.0)) continue;
      collision += h * h;
      if (!with_gradient) continue;
      // g_mean and g_cov are divided by the camera count below.
      g_mean[p] += scale * (-2.0 * h * f) * x;
      g_mean[q] += scale * (2.0 * h * f) * x;
      const Eigen::Matrix3d g = scale * h * f * x * x.transpose();
      g_cov[p] += g;
      g_cov[q] += g;
    }
  }
  // Joint-range prior (EnergyParams::joint_range_weight, thumb_range_weight).
  double range = 0.0;
  PoseVector range_gradient = PoseVector::Zero();
  if (params_.joint_range_weight > 0.0 || params_.thumb_range_weight > 0.0) {
    for (int j = 0; j < kNumJointDof; ++j) {
      const JointDof& limits = model_.joints[j];
      const double half_width = 0.5 * (limits.max - limits.min);
      const double weight = range_weights_[j];
      if (!(half_width > 0.0) || !(weight > 0.0)) continue;
      const double residual = (pose.joints[j] - 0.5 * (limits.max + limits.min)) / half_width;
      range += weight * residual * residual;
      range_gradient[kFirstJointDof + j] = weight * 2.0 * residual / half_width;
    }
  }
  // Wrist prior (EnergyParams::wrist_weight): rho = 1 - exp(-h^2 / 2), h = (d - tolerance) /
  // scale beyond the tolerance; drho/dt = exp(-h^2 / 2) h / scale * p / d, p the wrist's offset
  // from the ray across it.
  double wrist = 0.0;
  Eigen::Vector3d wrist_gradient = Eigen::Vector3d::Zero();
  if (params_.wrist_weight > 0.0 && !wrist_rays_.empty() && !forearm_present_) {
    for (const Ray& ray : wrist_rays_) {
      const Eigen::Vector3d offset = pose.translation - ray.origin;
      const Eigen::Vector3d across = offset - offset.dot(ray.direction) * ray.direction;
      const double distance = across.norm();
      if (!(distance > params_.wrist_tolerance)) continue;
      const double h = (distance - params_.wrist_tolerance) / params_.wrist_scale;
      const double e = std::exp(-0.5 * h * h);
      wrist += 1.0 - e;
      wrist_gradient += (e * h / (params_.wrist_scale * distance)) * across;
    }
    wrist /= static_cast<double>(wrist_rays_.size());
    wrist_gradient /= static_cast<double>(wrist_rays_.size());
  }
  const double total = similarity - params_.limit_weight * penalty -
                       params_.dip_pip_coupling_weight * coupling -
                       params_.finger_order_weight * order - params_.fan_turn_weight * fan_turn -
                       params_.finger_collision_weight * collision - range -
                       params_.wrist_weight * wrist;  // paper eq. 9 + priors

  if (terms) {
    terms->similarity = similarity;
    terms->limit_penalty = penalty;
    terms->coupling_penalty = coupling;
    terms->order_penalty = order;
    terms->fan_turn_penalty = fan_turn;
    terms->collision_penalty = collision;
    terms->range_penalty = range;
    terms->wrist_penalty = wrist;
    terms->total = total;
    for (double& value : terms->per_camera) value /= camera_count;
  }
  if (!with_gradient) return total;

  // Chain through the kinematics: each parameter moves a Gaussian rigidly (translation, or
  // rotation about a world axis through a pivot).
  gradient->setZero();
  for (size_t p = 0; p < num_gaussians; ++p) {
    const Eigen::Vector3d gm = g_mean[p] / camera_count;
    const Eigen::Matrix3d gc = g_cov[p] / camera_count;
    const WorldGaussian& world = hand.gaussians[p];
    for (int i = 0; i < 3; ++i) (*gradient)[kRootTranslation + i] += gm[i];
    // A turn by d about `axis` through a pivot moves the mean by d axis x (mean - pivot) and the
    // covariance C by d ([axis]x C - C [axis]x). With G = gc and C symmetric,
    // tr(G ([a]x C - C [a]x)) = tr((C G - G C) [a]x) = a . w, w the axial vector below, and
    // gm . (a x r) = a . (r x gm): one dot product per parameter.
    const Eigen::Matrix3d commutator = world.cov * gc - gc * world.cov;
    const Eigen::Vector3d w(commutator(1, 2) - commutator(2, 1),
                            commutator(2, 0) - commutator(0, 2),
                            commutator(0, 1) - commutator(1, 0));
    auto add_rotation = [&](int parameter) {
      const Eigen::Vector3d& axis = hand.dof_axis[parameter];
      (*gradient)[parameter] += axis.dot((world.mean - hand.dof_pivot[parameter]).cross(gm) + w);
    };
    if (p >= num_hand_gaussians) {
      // The forearm moves with the wrist; it turns with the hand only when it has no direction
      // of its own.
      if (!forearm_direction) {
        for (int i = 0; i < 3; ++i) add_rotation(kRootRotation + i);
      }
      continue;
    }
    for (int i = 0; i < 3; ++i) add_rotation(kRootRotation + i);
    for (int dof : ancestor_dofs_[model_.gaussians[p].bone]) add_rotation(kFirstJointDof + dof);
  }
  *gradient -= params_.limit_weight * limit_gradient;
  *gradient -= params_.dip_pip_coupling_weight * coupling_gradient;
  *gradient -= params_.finger_order_weight * order_gradient;
  *gradient -= params_.fan_turn_weight * fan_turn_gradient;
  *gradient -= range_gradient;
  for (int i = 0; i < 3; ++i) {
    (*gradient)[kRootTranslation + i] -= params_.wrist_weight * wrist_gradient[i];
  }
  return total;
}

}  // namespace sag_hand_tracker

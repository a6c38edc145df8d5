// The pose fitting energy E(Theta) = E_sim - w_l E_lim (paper eqs. 6-9) and its exact gradient.
#pragma once

#include <array>
#include <optional>
#include <tuple>
#include <vector>

#include "sag_hand_tracker/camera/camera.h"
#include "sag_hand_tracker/energy/colour.h"
#include "sag_hand_tracker/energy/overlap.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/model/pose.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

struct EnergyParams {
  double limit_weight = 0.1;  // w_l of paper eq. 9
  // Common factor on the model Gaussians' weights w_p^h of eq. 8. Below 0.5 a single projected
  // Gaussian cannot saturate an image Gaussian (D_pq < 2 E_qq), so the energy has a peak at the
  // true pose instead of a flat plateau; overlapping model Gaussians still saturate (occlusion).
  double model_weight = 0.5;
  ColourSimilarityParams colour;
  // Correct each frame's colour cast (ColourCast, colour.h) before d(c_p, c_q): the foreground's
  // area-weighted mean colour over all cameras is mapped onto the model's. Pose-independent, once
  // per frame. Gains are limited to [1 / max_colour_gain, max_colour_gain].
  bool correct_colour_cast = true;
  double max_colour_gain = 3.0;
  // Pairs whose Mahalanobis term exceeds this are skipped: exp(-30) ~ 1e-13 of the pair's peak.
  double max_mahalanobis_sq = 60.0;
  // The pair kernels (overlap.h) in float: twice the SIMD lanes, a tracking step 1.4 times
  // faster (doc/history.md "Session 13"). The energy then carries float rounding (about 1e-7 of its
  // value), too much for central differences; false computes them in double.
  bool float_pairs = true;
  // The saturation of eq. 8: 0 is the paper's min(S_q, E_qq) with S_q = sum_p w_p E_pq; a in
  // (0, 1] blends in a soft cap, (1 - a) min(S_q, E_qq) + a E_qq (1 - exp(-S_q / E_qq)), which
  // rises as steeply at 0 and approaches the same cap smoothly, so that a second model Gaussian
  // on a foreground region gains less than the first (curled fingers, issue 9: two straight
  // model fingers on one real finger) and one on an already covered region still gains a
  // little. Studio bags, default model (doc/history.md "Session 6"): 0.5 took fingercount, flexex1
  // and tigergrasp (7 hands) from 30.7 to 23.0 mm and the open adbadd, fingerwave, pinch, random (4
  // hands) from 17.1 to 14.9 mm; 1 helped the curled ones as much (22.8) and cost the open (26.2
  // on 3 hands, against 18.7).
  double saturation_softness = 0.5;
  // PIP-DIP coupling (as in Sridhar et al.'s successors and most hand trackers): a soft prior
  // -w_c sum_f (theta_dip - k theta_pip)^2 over the four fingers whose joints are named
  // <finger>_pip_flex / <finger>_dip_flex, k = `dip_pip_ratio`. 0 disables it. It resolves part
  // of the ambiguity of curled fingers (benchmark: fingercount, flexex1).
  double dip_pip_coupling_weight = 0.05;
  double dip_pip_ratio = 2.0 / 3.0;
  // Finger order (issue 9, stacked fingers): neighbouring long fingers do not cross. A soft prior
  // -w_o sum max(0, theta_abd(ulnar) - theta_abd(radial) - m_o)^2 over the pairs index-middle,
  // middle-ring, ring-pinky (<finger>_mcp_abd, positive toward the thumb): two fingers may turn
  // toward each other by `finger_order_margin` rad, further at a cost. Without it the tracked
  // hand often had neighbours turned toward each other up to both limits (0.7 rad; the studio's
  // truth stays within 0.21 in every motion but `random`, whose independent random joints cross
  // fingers as no hand can), the model's next finger laid along an opened real finger. Benchmark,
  // default model, 84 runs: pooled 14.5 -> 13.6 mm, fingercount 28.5 -> 26.8, random 21.9 ->
  // 19.0; fitted models 10.8 -> 10.4 (doc/history.md "Session 24"). 0 disables it.
  double finger_order_weight = 0.25;
  double finger_order_margin = 0.08;
  // The long fingers turned sideways together (issue 9; opt-in). A soft prior
  // -w_f max(0, |c| - m_f)^2, c the mean MCP abduction (<finger>_mcp_abd) of the long fingers: the
  // fingers may fan out and close freely, but their common turn beyond `fan_turn_margin` rad
  // costs. The palm's turn about its normal and all four fingers' abductions the other way put the
  // fingers in nearly the same place, and the energy tells them apart poorly where the fingers are
  // curled: the tracker had |c| above 0.15 rad in 16-53 % of the frames of every studio motion
  // (fingercount, flexex1, raised about half), with the palm turned by up to 35 degrees, where
  // the truth's |c| never exceeds 0.14. With w_f 0.3 no tracked |c| exceeded 0.25 (14 % of the
  // frames before) and frames with the palm turned by more than 10 degrees went 10.3 -> 8.7 %
  // (default model) and 5.9 -> 5.1 % (fitted); benchmark, 17 hands x 12 motions: default model
  // 10.21 -> 10.20 mm pooled (the default hand 8.13 -> 8.54), fitted models 8.53 -> 8.32, no frame
  // reversed or rolled over; but five of the tracker's behaviour tests failed with it (the
  // kitchen's fitted model on the other arm 15 frames longer, the open and curl toggles' scenes),
  // and w_f 0.5 and 1 rolled tracks over (doc/history.md "Session 46"). 0 disables it.
  double fan_turn_weight = 0.0;
  double fan_turn_margin = 0.15;
  // Finger collision (opt-in): two fingers cannot lie in one place. A soft prior
  // -w_k sum max(0, f_pq - f_0)^2 over the model Gaussians p, q of neighbouring long fingers
  // (index-middle, middle-ring, ring-pinky), f_pq = exp(-1/2 d^T (Sigma_p + Sigma_q)^-1 d) with
  // d = mu_p - mu_q: 1 where two Gaussians coincide, about 0.15-0.35 for fingers side by side
  // in an open hand. Unlike the order prior it charges only fingers that are close in 3D, i.e. a
  // straight model finger laid along its straight neighbour (fingercount's stacked finger).
  // Benchmark, 84 + 84 runs (doc/history.md "Session 25: finger collision"): w_k 0.1, f_0 0.4 took
  // fingercount from 26.9 to 25.3 mm and the fitted models from 10.6 to 10.2 mm pooled, but the
  // default model's pooled error from 13.6 to 13.9 (random 19.0 -> 21.6); 0.2 / 0.55 made
  // fingercount worse (28.3). 0 disables it.
  double finger_collision_weight = 0.0;
  double finger_collision_threshold = 0.4;
  // The wrist where the sleeve meets the hand (issue 9: "the forearm joins the hand at the wrist
  // in every camera"). Each camera whose segmentation found at least `wrist_min_cells` cells of
  // forearm evidence (ImageSoG::arm_cells: the sleeve's cells next to the hand) gives a ray
  // through their centroid; the prior is -w_s mean_c rho(d_c), d_c the distance (m) of the wrist
  // (the root) from camera c's ray, rho(d) = 1 - exp(-h^2 / 2) with h = max(0, d - tolerance) /
  // scale. The band's centroid lies a little up the arm and off the axis (median 12-19 mm from
  // the true wrist on the studio's sleeved sequences, 90th percentile 22-33 mm), so nothing is
  // charged within the tolerance; rho is bounded, so a camera whose evidence lies far off (a bare
  // forearm: the sleeve begins up the arm, 60-240 mm away) pulls little. Off while the forearm
  // is part of the energy (setForearmPresent: a bare forearm). 0 disables it.
  double wrist_weight = 0.01;
  double wrist_tolerance = 0.035;
  double wrist_scale = 0.025;
  int wrist_min_cells = 6;
  // Joint-range prior (issue 9): -w_r sum_j ((theta_j - m_j) / h_j)^2 with m_j the middle and h_j
  // half the width of joint j's limits. Where the images say little about a finger (a model
  // larger than the hand, a finger hidden behind the palm) the capped overlap of eq. 8 has no
  // gradient, and such fingers drifted to their limits: the thumb folded across the palm, a
  // finger curled into a fist over the palm's saturated foreground. The prior pulls them gently
  // to the middle of their range. Off by default: at 0.003 it helped curled and small hands a
  // little and cost the open default hand more (adbadd 6.2 -> 12.7 mm; doc/history.md).
  double joint_range_weight = 0.0;
  // The same prior on the thumb's four joints alone, with this weight in place of
  // joint_range_weight. Cameras above a table do not see the thumb of a palm-down fist (tucked
  // under the fingers: the truth's and the track's silhouettes within 0.004 Dice), and it drifts
  // to its limits (40 mm off on fingercount's default hand). At 0.003 the benchmark went 13.09 ->
  // 12.94 mm pooled and fingercount 25.6 -> 22.6, but a thumb pulled off a visible pose turns
  // the palm: the counter-turn start's roll that turns back went from 0.04 to 0.09-0.21 rad
  // (TrackerOrientation.CounterTurn*). Off by default; doc/history.md "Session 28". Held only while
  // no camera saw the thumb (its phalanges' visible share, visibility.h) or only in a fist, it lost
  // the gain (doc/history.md "Session 29").
  double thumb_range_weight = 0.0;
  // lambda of the per-camera normalisation E_c = (1 + lambda) O_c / (I_c + lambda M_c), with O_c
  // the capped overlap of eq. 8, I_c = sum_q E_qq the image's foreground area and M_c the projected
  // model's area (sum_p w_p 2 pi sqrt|Sigma_p|, the mass a model Gaussian would cover on a
  // foreground of density 1). 0 is the paper's O_c / I_c, which rewards a hand that comes closer
  // to one camera (its projection grows and saturates more image Gaussians); 1 is a Dice
  // coefficient: model area that finds no foreground (too large, outside the image) counts
  // against the pose, so the fit cannot buy similarity by growing in one view. Default 0: on the
  // studio benchmark 1 cost accuracy (SAG pooled 17.2 -> 21.7 mm with the tracker's flip guards,
  // flexex1 and tigergrasp worst; README "Where it falls short"), so it is opt-in until the
  // double-counted area of overlapping model Gaussians is handled.
  double model_area_weight = 0.0;
  // Occlusion (visibility.h): each model Gaussian counts, in eq. 8's overlap and in M_c, with the
  // share v_p of it that the camera sees past the model Gaussians in front of it, in a soft depth
  // order of this scale (m); 0: every v_p = 1, the paper's eq. 8. Gaussians of one bone, or of a
  // bone and its parent, are one surface and do not hide each other (nor the forearm and the
  // palm), so that an open hand counts as without occlusion. Eq. 8's cap alone lets a model
  // Gaussian hidden behind the palm still take credit, and M_c without it counts a finger curled
  // over the palm as much area as one straight out over the background.
  double occlusion_depth_scale = 0.0;
  // The forearm (issue 9). A bare forearm is skin-coloured foreground that a hand-only model
  // cannot explain; with the capped overlap of eq. 8 the fingers and the palm then slide onto it
  // whenever the hand's own foreground is smaller (a fist, a flexed wrist): the studio's
  // `wristflex` scored the hand slid 8 cm up the arm above the true pose (0.52 against 0.39).
  // `forearm_gaussians` Gaussians (0: none) along a forearm of `forearm_length` (m), starting
  // `forearm_gap` behind the wrist (the root), `forearm_sigma` across, each half its share of the
  // length along, with the model's mean colour and weight `forearm_weight`, explain it. The arm
  // is part of the energy only once setForearmPresent(true) says the images show it (the tracker
  // decides that from how much foreground it explains: TrackerParams::forearm_min_gain). It has
  // no pose parameters of its own: by default it continues straight on from the palm (the root's
  // -x axis, rigid with the hand: what the start hypotheses assume), and setForearmDirection gives
  // it a world direction of its own instead (the tracker's, refined per frame by
  // refineForearmDirection in optimizer.h), so that the wrist can flex under it.
  int forearm_gaussians = 4;
  double forearm_length = 0.20;
  double forearm_gap = 0.01;
  double forearm_sigma = 0.02;
  double forearm_weight = 1.0;
};

// One camera's input for a frame: calibration and the image SoG (undistorted pixels).
struct CameraObservation {
  Camera camera;
  ImageSoG sog;
};

// Per-camera breakdown, for diagnostics and the overlay.
struct EnergyTerms {
  double similarity = 0.0;        // E_sim, normalised: mean over cameras of E_c (model_area_weight)
  double limit_penalty = 0.0;     // E_lim
  double coupling_penalty = 0.0;  // sum_f (theta_dip - k theta_pip)^2 (EnergyParams)
  double order_penalty = 0.0;     // sum max(0, abd_ulnar - abd_radial - m_o)^2 (EnergyParams)
  double fan_turn_penalty = 0.0;  // max(0, |mean long-finger abduction| - m_f)^2 (EnergyParams)
  double collision_penalty = 0.0;  // sum max(0, f_pq - f_0)^2 (EnergyParams)
  double range_penalty = 0.0;      // sum_j w_j ((theta_j - m_j) / h_j)^2, w_j its weight
                                   // (joint_range_weight, or thumb_range_weight for the thumb)
  double wrist_penalty = 0.0;      // mean_c rho(d_c), the wrist's distance from the sleeve's end
  // E_sim - w_l E_lim - w_c coupling - w_o order - w_f fan turn - w_k collision - range - w_s wrist
  double total = 0.0;
  std::vector<double> per_camera;
  // Model Gaussians that could not be projected into a camera that sees foreground (behind it,
  // containing its centre, closer than 1 cm to its plane), summed over those cameras. Each counts
  // against the pose with area w_p I_c / sum_p w_p.
  int invalid_projections = 0;
};

// Holds what does not depend on the pose for one frame (colour similarities, E_qq), so that the
// optimizer's iterations evaluate only the pose-dependent part.
// The forearm's Gaussians (EnergyParams::forearm_*) along the unit `direction` from `wrist`: their
// means, and the one covariance they share. The energy's and the test scenes' forearm.
struct ForearmGaussians {
  std::vector<Eigen::Vector3d> means;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Identity();
};
ForearmGaussians forearmGaussians(const EnergyParams& params, const Eigen::Vector3d& wrist,
                                  const Eigen::Vector3d& direction);

class PoseEnergy {
 public:
  PoseEnergy(const HandModel& model, const EnergyParams& params);

  // Sets the frame: cameras and image SoGs. Computes d(c_p, c_q) once per pair.
  void setFrame(const std::vector<CameraObservation>& observations);

  // E(Theta); with `gradient`, also dE/dTheta (orientation in the tangent space, see pose.h).
  double evaluate(const Pose& pose, PoseVector* gradient = nullptr,
                  EnergyTerms* terms = nullptr) const;
  // The same with the forearm present along `forearm_direction` (a world direction from the
  // wrist, normalised here), whatever setForearmPresent and setForearmDirection say.
  double evaluateWithForearm(const Pose& pose, const Eigen::Vector3d& forearm_direction) const;

  // lambda of E_c (EnergyParams::model_area_weight) for the next evaluations: the tracker scores
  // its starts with another one than its tracking (TrackerParams::start_model_area_weight).
  // Nothing computed per frame depends on it. Throws InputError unless finite and >= 0.
  void setModelAreaWeight(double weight);
  // EnergyParams::occlusion_depth_scale for the next evaluations (0: no occlusion): the tracker
  // refines curled fingers with occlusion and the model's area (TrackerParams::curled_refine_*).
  void setOcclusionDepthScale(double scale);

  // Whether the forearm's Gaussians (EnergyParams::forearm_gaussians) are part of the energy
  // (default: no), and their world direction from the wrist; empty: straight on from the palm,
  // rigid with the hand (the default). Both are kept across setFrame.
  void setForearmPresent(bool present) { forearm_present_ = present; }
  bool forearmPresent() const { return forearm_present_ && params_.forearm_gaussians > 0; }
  void setForearmDirection(const std::optional<Eigen::Vector3d>& direction);
  const std::optional<Eigen::Vector3d>& forearmDirection() const { return forearm_direction_; }
  // The forearm's direction for `pose`: the set one, or straight on from the palm.
  Eigen::Vector3d forearmDirectionFor(const Pose& pose) const;

  const HandModel& model() const { return model_; }
  const EnergyParams& params() const { return params_; }
  int numCameras() const { return static_cast<int>(cameras_.size()); }

 private:
  template <typename T>
  struct PairInputs {
    ImageGaussianArraysOf<T> image_gaussians;
    // Row p: w_p d(c_p, c_q) for every image Gaussian q. The colour term does not depend on the
    // pose, so it is computed once per frame.
    std::vector<T> weights;
  };
  struct FrameCamera {
    Eigen::Matrix3d rotation;  // root -> camera
    Eigen::Vector3d translation;
    Eigen::Matrix3d K;
    // In the pair kernels' precision (EnergyParams::float_pairs); only that one is filled.
    std::tuple<PairInputs<float>, PairInputs<double>> pairs;
    double image_area = 1.0;  // I_c = sum_q E_qq
  };

  // p indexes the model's Gaussians, then the forearm's.
  double modelWeight(size_t p) const;
  size_t numGaussians() const;
  double evaluateImpl(const Pose& pose, bool with_forearm,
                      const std::optional<Eigen::Vector3d>& forearm_direction, PoseVector* gradient,
                      EnergyTerms* terms) const;
  // evaluateImpl with the pair kernels in T.
  template <typename T>
  double evaluateIn(const Pose& pose, bool with_forearm,
                    const std::optional<Eigen::Vector3d>& forearm_direction, PoseVector* gradient,
                    EnergyTerms* terms) const;
  Hsv model_mean_colour_ = Hsv::Zero();  // area-weighted mean of the model Gaussians' colours

  HandModel model_;
  EnergyParams params_;
  std::vector<std::vector<int>> ancestor_dofs_;       // per bone
  std::array<double, kNumJointDof> range_weights_{};  // w_j of the joint-range prior
  std::vector<std::pair<int, int>> pip_dip_pairs_;    // joint indices of coupled PIP, DIP
  // Joint indices of neighbouring fingers' MCP abductions (radial, ulnar): the finger order prior.
  std::vector<std::pair<int, int>> abduction_neighbours_;
  // Joint indices of the long fingers' MCP abductions: the fan-turn prior.
  std::vector<int> long_finger_abductions_;
  // Model Gaussian pairs of neighbouring long fingers: the finger collision prior.
  std::vector<std::pair<int, int>> collision_pairs_;
  // occluding_pairs_[p * numGaussians() + r]: whether r may hide p (visibility.h).
  std::vector<char> occluding_pairs_;
  std::vector<FrameCamera> cameras_;
  // Per camera with forearm evidence (EnergyParams::wrist_weight): the ray through its centroid.
  std::vector<Ray> wrist_rays_;
  bool forearm_present_ = false;
  std::optional<Eigen::Vector3d> forearm_direction_;
};

// isInFrontOfCameras (camera.h) for the cameras of a frame's observations.
bool isInFrontOfCameras(const Eigen::Vector3d& point,
                        const std::vector<CameraObservation>& observations,
                        double min_depth = 0.05);

}  // namespace sag_hand_tracker

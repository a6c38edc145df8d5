// The tracker: per frame, image SoGs of N cameras -> optimised hand pose, with warm start,
// automatic start (no manual initial pose) and restart when the track is lost.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sag_hand_tracker/energy/energy.h"
#include "sag_hand_tracker/energy/silhouette.h"
#include "sag_hand_tracker/optimization/optimizer.h"
#include "sag_hand_tracker/tracking/colour_adaptation.h"

namespace sag_hand_tracker {

enum class TrackStatus {
  kWaiting,   // no hand seen yet (or not enough foreground in the cameras)
  kStarted,   // this frame started (or restarted) the track from hypotheses
  kTracking,  // warm-started from the previous frames
  kLost,      // the energy says the track is lost; the next frame restarts
};
std::string toString(TrackStatus status);

struct TrackerParams {
  EnergyParams energy;
  OptimizerParams optimizer;
  // Automatic start: minimum number of image Gaussians in a camera to count it as seeing the hand,
  // and in how many cameras that must hold.
  int min_foreground_gaussians = 8;
  int min_cameras_for_start = 2;
  // Iterations spent on each start hypothesis.
  int start_iterations = 40;
  // Every this many tracked frames, the start routine runs as well and replaces the tracked pose
  // when it finds a clearly better one (energy higher by `redetect_margin`); 0 disables it. This
  // recovers tracks that converged to a wrong but stable pose, which the similarity cannot flag.
  int redetect_interval = 25;
  double redetect_margin = 0.005;
  // A search made while the tracker has a pose (a re-detection, or a restart after a loss: that
  // pose is one of its candidates) refines only this many of its scored orientation hypotheses in
  // the coarse stage (the first start: 24). The searches are about half of all optimisation
  // offline; on 28 bags
  // of the benchmark 12 gave the same errors as 24 but on one bag (0.1 mm) for ~8 % less
  // optimisation, while 8 moved `fastturn` by up to 5 mm and 20 final iterations instead of
  // `start_iterations` cost 0.7 mm pooled (session 7).
  int redetect_coarse_kept = 12;
  // How many coarse-refined candidates get all `start_iterations`: a search without a pose (the
  // first start) keeps `start_kept`, one with a pose (re-detection, restart after a loss) 4. The
  // first start is rare, so it can afford more. With 4, `wristflex` on `long_distal_large` with
  // its fitted model started reversed (energy 0.35; the right pose, 0.62, ranked fifth or lower
  // after the coarse stage) and stayed so for 65 frames (doc/history.md "Session 13").
  int start_kept = 8;
  // In a search with a pose (re-detection, restart after a loss) the last stage races: every
  // candidate gets `redetect_race_iterations` of its `start_iterations`, then only the best
  // `redetect_race_kept` (by energy) get the rest; the others end as they are, ranked below
  // them. On the benchmark's 77 default-model runs 5 and 2 changed one track (14.33 mm pooled
  // either way) and optimisation per frame fell ~8 % (doc/history.md "Session 17"); 10 and 1
  // changed ten (14.48 mm). 0 (or >= start_iterations): every candidate gets all of them.
  int redetect_race_iterations = 5;
  int redetect_race_kept = 2;
  // The track counts as lost when the normalised similarity drops below `lost_similarity`, or
  // below `lost_ratio` times its running average over the recent tracked frames.
  double lost_similarity = 0.15;
  double lost_ratio = 0.7;
  // lambda of the energy's normalisation (EnergyParams::model_area_weight) while the tracker
  // starts (no track, or the track was lost): the start's hypotheses are refined and ranked with
  // the larger of this and energy.model_area_weight, the tracked frames with the latter. A start
  // has no track to stay near, and where the foreground holds more than the hand (the skin gate's
  // wooden table) the paper's normalisation ranks first a hand grown toward one camera inside a
  // large blob: in the studio's kitchen the start of a hand larger than the model ended 115 mm off
  // and climbed 20 cm off the table. Tracking with lambda 1 as well costs the hands whose
  // foreground misses part of them (a dark hand's fingertips: the Dice curls the finger away).
  // Every frame reports the tracking energy's terms. 0 (the default): the paper's.
  // TrackingPipeline sets it with the generic skin gate (PipelineParams::
  // skin_gate_start_area_weight; doc/segmentation.md, "Session 33").
  double start_model_area_weight = 0.0;

  // Orientation guard (issue 9). A candidate is a *flip* of the tracked pose when its back-of-hand
  // normal or its wrist->middle-knuckle axis is more than 90 degrees from the tracked pose's (a
  // rolled-over or reversed hand). A small energy gain never justifies a flip: a re-detection that
  // finds one only starts carrying it as a second hypothesis, optimised every frame from its own
  // previous pose like the track; it replaces the track when its energy has been above the
  // track's by `flip_margin` on `flip_confirm_frames` frames (a *win*). The wins need not be
  // consecutive: it is kept while its energy stays above the track's by more than
  // `flip_keep_margin`, and dropped when it does not, or when it has not won often enough within
  // `flip_max_frames` carried frames (0: no limit). On the studio's `fastturn` a true flip carried
  // through a fast turn won 4 times, then by 0.016 only, and was dropped when the wins had to be
  // consecutive (flip_keep_margin = flip_margin, flip_max_frames = flip_confirm_frames).
  double flip_margin = 0.02;
  int flip_confirm_frames = 5;
  double flip_keep_margin = 0.0;
  int flip_max_frames = 15;
  // A flip back. The guard above protects whatever the track is, also a track that has itself
  // turned over while following a fast turn (it slid or rolled instead): the true pose is then a
  // flip of the track and is only carried, and a rolled track scoring within flip_margin of it
  // kept it out. A re-detection candidate that is a flip of the track but no flip of the track's
  // own orientation on one of its last `flip_return_frames` frames, while the track is a flip of
  // that orientation, returns the hand to where the track was before it turned over; it is judged
  // as no flip (adopted when better by redetect_margin, without redetect_turn_angle's margin).
  // Since the last start or flip. On the studio's fastturn a drawn hand's track (drawn3) slid off
  // a roll of 0.3 rad per frame, was reversed for 4 frames and came back 4 frames later; with
  // 50 it came back on the next re-detection and no frame was reversed; the other 168 + 191 tracks
  // of the named and 8 drawn hands were byte-identical (doc/history.md "Session 31"). 0 disables.
  int flip_return_frames = 50;
  // A re-detection candidate turned further than `redetect_turn_angle` (radians) from the track,
  // though no flip, needs flip_margin instead of redetect_margin to be adopted: on the studio's
  // `raised` such a turn of 88 deg, 0.013 better, was the start of a rolled-over stretch. 0
  // disables it.
  double redetect_turn_angle = 1.05;
  // Likewise a candidate whose fingers are curled differently from the track's by more than
  // `redetect_flexion_change` (radians of meanFingerFlexion, MCP + PIP averaged over the four
  // fingers: an open hand about 0, a fist above 1.9): a hand does not open or close its fist
  // between two frames. On `raised`, an open hand turned 51 deg from long_distal_small's correctly
  // tracked fist scored 0.013 better and replaced it; the fist was lost for 100 frames (40 mm).
  // 0 disables it.
  double redetect_flexion_change = 1.0;
  // A re-detection adopted in place of the track (no flip, and within max_rotation_per_frame of
  // the track's pose on that frame) goes on with the track's motion (poseBeforeMotion) instead of
  // starting still. On the studio's `fastturn` a re-detection adopted in a roll of 28 degrees per
  // frame reset it, the next frames could turn only max_rotation_change_per_frame more than the
  // still start, and the track stayed behind until it had rolled over (4 frames, dark_small).
  // Benchmark, 84 default-model runs: 0 rolled-over frames instead of 4, pooled 13.6 mm either
  // way (doc/history.md "Session 25").
  bool redetect_keeps_motion = true;
  // How fast the hand may turn (radians per frame). The optimiser starts each frame from the pose
  // predicted at constant velocity (its turn capped at `max_rotation_per_frame`); its result may
  // differ from that prediction's orientation by at most `max_rotation_change_per_frame`, and from
  // the previous frame's by at most `max_rotation_per_frame`; a larger turn is pulled back. A real
  // hand speeds up its turn over several frames and never flips in one: 0.45 rad per frame at
  // 25 fps is 640 deg/s, above the fastest turns of a forearm and wrist, and the change bound lets
  // a turn reach that in 3 frames (0.1 was worse on the benchmark's raised, wristflex and fastturn
  // sequences, 0.3 the same as 0.2; doc/history.md). A bound on the turn itself, not its change,
  // kept fast turns from being followed (at 0.1 rad, 143 deg/s, a 500 deg/s turn rolled the track
  // over). A turn the bounds cannot follow ends in the lost test and a restart instead. 0 disables
  // a bound.
  double max_rotation_per_frame = 0.45;
  double max_rotation_change_per_frame = 0.2;
  // The counter-turn start: a hand seen turning about its own long axis looks much the same
  // turning either way, and a track that turned the wrong way is carried on by the constant-
  // velocity prediction until it has rolled over (the studio's `raised`, `fastturn`, `random`:
  // every rolled-over stretch began so, in tracking). When the track turned by more than
  // `counter_turn_min_angle` (radians) in the last frame, the frame is also optimised from the
  // prediction with that turn reversed, and the better result (energy) is kept. It costs a second
  // optimisation in those frames (65-93 % of the frames of the studio's sequences at 1 deg):
  // optimisation +25-30 % per frame, frames/s -15-20 %. Subset of the benchmark (raised,
  // fastturn, random x 4 hands): 30.8 -> 30.4 mm, rolled over 9.3 -> 1.5 %; the 7 Dexter
  // sequences, default hand: 17.7 -> 15.6 mm (doc/history.md, session 6).
  bool counter_turn_start = true;
  double counter_turn_min_angle = 0.0175;
  // The two starts race: each is optimised for this share of the optimiser's iterations, then
  // only the one with the higher energy goes on for the rest (0 or 1: both get all iterations).
  // Raced at half the iterations, the benchmark's 77 default-model runs went from 14.4 mm pooled
  // and 0.09 % rolled over to 14.3 mm and none, and optimisation per frame from 3.69 to 3.20 ms
  // (frames/s 215 -> 241, medians of an interleaved run); a quarter gave 14.5 mm, 0.4 gave
  // 14.6 mm and 0.28 % rolled (doc/history.md "Session 17"). calibrate_hand tracks without it.
  double counter_turn_race_share = 0.5;
  // More iterations only where the frame's ascent is still rising (issue 9, item 4): after the
  // optimiser's iterations, up to rising_extra_iterations more, in chunks of rising_chunk, while
  // the best energy rose by more than rising_min_gain over the last chunk; not in a track's first
  // rising_min_track_frames frames, whose start in a cluttered room turns on energy differences
  // this small (without the wait the kitchen's tracks start on the other arm). At 10 / 1e-3 / 8,
  // the default model over 17 hands averaged over 19, 20 and 21 iterations (one run moves by
  // +-0.3 mm with any change; doc/history.md "Session 47"): 10.35 -> 10.22 mm, the three runs
  // within 0.05 mm of each other instead of 0.28, no track above 26.1 mm (29.4); fitted models
  // 8.45 -> 8.37 at 20. Both of a counter-turn's starts get them (TrackerOrientation tests). The
  // live graph runs them too (cfg/Tracker.cfg: no latency cost measured); calibration's routine
  // does not (RoutineTracking).
  int rising_extra_iterations = 10;
  int rising_chunk = 5;
  double rising_min_gain = 1e-3;
  int rising_min_track_frames = 8;
  // Finger toggles judged by the silhouette (issue 9, doc/history.md "Session 27"). The energy
  // scores a long finger tracked straight over its opened neighbour, or out where the truth has it
  // curled, as well as the curled truth (eq. 8 never charges model over background), and the
  // frame's ascent does not leave that state. After each tracked frame every long finger tracked
  // straight (MCP + PIP flexion below toggle_straight_flexion) is tried curled (MCP toggle_mcp, PIP
  // toggle_pip, DIP by the coupling's ratio, abduction 0) and refined for toggle_iterations; the
  // best one replaces the track when E + toggle_silhouette_weight * D rises by more than
  // toggle_min_gain, D the silhouette score (silhouette.h) at toggle_silhouette_sigmas. A toggle
  // whose unrefined silhouette score falls by more than toggle_max_silhouette_loss (an open
  // finger seen in the images) is not refined. Not on a track that looks lost (lost_similarity,
  // lost_ratio), nor in the first toggle_min_track_frames frames after a start or an adopted
  // re-detection, whose fingers are the search's (toggled there, the studio kitchen's track on the
  // other arm held 4 frames longer against the user's hand); a periodic re-detection that keeps
  // the track does not stop them (until session 34 it did, for 8 of every 25 frames).
  // The other way (session 40): a long finger tracked curled (MCP + PIP flexion above
  // toggle_curled_flexion) is tried open (MCP, PIP and DIP 0, its abduction kept), judged alike:
  // the frame's ascent does not take a finger out of the palm when the images show it opened in
  // one frame (doc/history.md "Session 40": `fingercount` on dark_small 25.8 -> 18.7 mm). Not
  // while the track turns by more than toggle_open_max_turn per frame: a fast turn changes the
  // outline, a finger opened on the wrong side covers it, and the hand rolls over to fit. Nor
  // with fewer than toggle_open_min_cameras views: with two or three the open toggles rolled
  // over two of the paper's camera subsets' tracks that had held (19 % of their frames).
  // Infinity disables only this way (TrackingPipeline and the tracker nodelet do without a plate:
  // PipelineParams::open_toggles_without_plate); toggle_silhouette_weight 0 disables both.
  double toggle_silhouette_weight = 0.5;
  double toggle_straight_flexion = 0.7;
  double toggle_mcp = 1.3;
  double toggle_pip = 1.6;
  int toggle_iterations = 10;
  double toggle_min_gain = 0.001;
  double toggle_silhouette_sigmas = 1.3;
  double toggle_max_silhouette_loss = 0.01;
  int toggle_min_track_frames = 8;
  double toggle_curled_flexion = 2.0;
  double toggle_open_max_turn = 0.15;  // radians per frame
  int toggle_open_min_cameras = 4;
  // Curled fingers refined with occlusion and the model's area (issue 9, doc/history.md
  // "Session 35: fists refined with the root held"). On `fingercount`'s curled frames (default
  // hand) the tracker's ascent, started at the true pose, slides the palm 3-5 mm and opens the
  // middle and ring MCP by 0.21-0.22 rad together; with the root held the same ascent keeps them
  // (0.01-0.08 rad), and the track was 0.44-0.52 rad short. So after each tracked frame whose mean
  // finger flexion (meanFingerFlexion) is at least curled_refine_flexion, the long fingers' joints
  // get curled_refine_iterations more iterations with the root and the thumb held, scored with
  // occlusion at curled_refine_occlusion_depth_scale (m; a finger curled under the palm earns
  // nothing where it is hidden) and lambda curled_refine_model_area_weight (a finger straightened
  // over the background costs); the frame reports the paper's energy of the result. The thumb is
  // held because that energy folds it (IP +0.42 rad from the truth), and a thumb folded into the
  // fist no longer tells its side: with it free one `fastturn` track reversed. Benchmark (168 named
  // tracks): default model 13.06 -> 12.22 mm pooled, `fingercount` 24.97 -> 22.82, no frame
  // reversed or rolled over; fitted models 9.96 -> 9.43, one of their tracks rolled over; drawn9-16
  // 11.89 -> 11.05, fitted 9.35 -> 8.56. Tracking with that energy throughout costs open hands
  // and hands unlike the model (session 11); with lambda 0.3 from a flexion of 1.2 or 1.4, tracks
  // rolled over. TrackingPipeline runs it with the background plate only
  // (PipelineParams::curled_refine_without_plate), calibrate_hand not while it tracks a routine
  // (calibrationTrackerParams). 0 iterations disables it.
  int curled_refine_iterations = 10;
  double curled_refine_flexion = 1.6;
  double curled_refine_model_area_weight = 1.0;
  double curled_refine_occlusion_depth_scale = 0.01;
  // The model's size follows the hand's (session 41, issue 9). A user's hand is rarely the model's
  // size, and a model smaller than the hand covers one long finger with two of its own: the next
  // finger of a count tracked straight beside the opened one (`fingercount` on the studio's
  // mesh_like hand, 6 % larger than the model with long distal phalanges: 38 mm; with the model
  // scaled by 1.06 by hand, 21 mm). The silhouette shows a hand's size where its fingers are
  // straight. So every size_interval-th frame of a held track whose long fingers are all
  // straighter than size_open_flexion (MCP + PIP), seen by at least size_min_cameras cameras,
  // without a bare forearm in the energy (forearm_min_gain: the foreground goes on past the wrist,
  // and the model grew along it to 1.15-1.2 on `wristflex`) and not turning by more than
  // size_max_turn per frame (the pose lags the images; `fastturn` on mesh_like read 1.13), the
  // model scaled about the wrist by 1 + size_step and by 1 - size_step is scored by the silhouette
  // (D at size_silhouette_sigmas) at the tracked pose refined for it by size_refine_iterations of
  // the optimiser (the tracked pose was fitted with the current size: a finger tracked a little
  // curled reads as a longer hand; scored at the tracked pose itself, the studio's default hand
  // read 1.02-1.04 and its tracks lost 15 %, session 42); the model takes the better one when D
  // rises by more than size_min_gain, within [size_min, size_max] times the size it was made with.
  // Only the lengths are scaled (scaleHandModel(f, 1)): the silhouette prefers Gaussians thinner
  // than the hand (doc/calibration.md), so the widths stay the model's. Kept through losses and
  // restarts (the same user); reset and setModel start again at 1. For a model from calibrate_hand
  // (colours fitted) only with size_calibrated_models: the fit reads most hands' fingers short
  // (doc/calibration.md "Session 43"), and the trial lengthens them again; calibrate_hand tracks
  // its routine with it and fits from the size it found (RoutineTracking). TrackingPipeline and the
  // tracker nodelet run it with a plate only (PipelineParams::size_adaptation_without_plate).
  // size_step 0 disables it. Without the refinement the silhouette at 1 sigma read the studio's
  // hands 4-8 % larger than they are, at 1.3 sigma 3-5 % smaller; at 1.15 within 3 % on five of
  // eight, 5 % on the others (doc/history.md "Session 41").
  double size_step = 0.02;
  int size_interval = 5;
  double size_open_flexion = 0.7;
  double size_min_gain = 0.001;
  double size_silhouette_sigmas = 1.15;
  int size_refine_iterations = 5;
  double size_max_turn = 0.15;  // radians per frame
  int size_min_cameras = 4;
  double size_min = 0.85;
  double size_max = 1.2;
  // The size trial for calibrate_hand's models too (above). Averaged over three benchmark draws
  // (19 / 20 / 21 iterations, the nine named hands; doc/history.md "Session 48") the fitted models
  // track at 8.49 mm instead of 8.68, each draw lower: stocky 10.78 -> 9.29 (its model ends at
  // 1.04), long_distal_large 10.72 -> 10.23, dark_small 6.94 -> 6.22, long_distal_small 8.82 ->
  // 8.65; the hands the fit got right lose 0.1-0.3 mm (the default hand 7.59 -> 7.72,
  // long_distal 9.01 -> 9.30, other_skeleton 7.34 -> 7.65, mesh_like 9.70 -> 10.03, slender 7.20
  // -> 7.29). What helps is that the trial's 1.15 sigma reads a model fitted at 1.3 sigma small,
  // so the trial grows every fitted model by 2-8 %. At the fit's own 1.3 sigma the sizes stay
  // near 1, and the fitted models track worse than with no trial (8.85 against 8.64 mm).
  bool size_calibrated_models = true;
  // Forearm cue: a camera whose segmentation found at least `min_arm_cells` sleeve cells
  // (ImageSoG::arm_cells) votes on which end of the hand is the wrist. Start hypotheses and
  // re-detections that point the wrist away from the arm (mean vote below `-arm_vote_threshold`)
  // are refused; a tracked pose with such a vote on `arm_reversed_frames` consecutive frames is
  // declared lost. `min_arm_cells` = 0 disables the cue.
  int min_arm_cells = 6;
  double arm_vote_threshold = 0.3;
  int arm_reversed_frames = 3;
  // Start prior for hands the silhouettes cannot resolve (issue 9): an open hand and the same hand
  // rolled over (turned 180 degrees about its wrist->knuckle axis) differ only in the thumb's
  // side, and on hands with other proportions than the model the energy often ties them. The
  // start also refines the rolled-over twin of its best candidate, and among the refined
  // candidates whose energy is within `start_facing_margin` of the best it takes the one whose
  // back of the hand faces the cameras most (cameras look at the back of a hand held over a
  // table far more often than at its palm). A clearly better candidate still wins; 0 disables
  // the prior (and the twin).
  double start_facing_margin = 0.03;
  // The forearm in the energy (EnergyParams::forearm_gaussians): after each frame, the tracked
  // pose is scored with and without the forearm (along its direction, refined every frame while
  // it is present); it is part of the next frame's energy when it adds more than
  // `forearm_min_gain` to the similarity, and stays while it adds more than half that. A bare
  // forearm adds 0.20-0.24 on the studio's `wristflex`, the bare wrist above a sleeve about 0.01
  // (a wrong track, e.g. a hand pointing along its own arm, more: 0.05 switched it on in
  // `fastturn`); a sleeved forearm does not switch it on, so those tracks are unchanged.
  double forearm_min_gain = 0.1;
  // A first start searches a second time with the forearm in the energy when the forearm gains
  // more than this at the best candidate or at it reversed (forearmMayBeBare); otherwise that
  // search would only be discarded. On the benchmark's 84 bags (12 sequences x 7 hands, session
  // 10) sleeved forearms gained at most 0.014 at the candidate and 0.103 reversed (where the
  // forearm lies over the fingers), and the bare ones of `wristflex` at least 0.141 at one of
  // them (0.052 and 0.23 on the one hand started reversed); the old test, 0.05 at either, ran the
  // second search, which doubles the start, on all 84 starts, and kept it on the 7 bare ones.
  double forearm_start_gain = 0.12;
  // ... and, whatever that test says, when the best candidate's energy is below this: a start that
  // explains the foreground poorly. The test looks only at that candidate, and a start that left a
  // bare forearm out can be wrong where the forearm gains little: the fitted model of the studio's
  // stocky hand started `wristflex` 93 mm off at 0.40, where the forearm straight on gains less
  // than 0.12 (refined, 0.065); with the forearm the true pose scores 0.63 (doc/history.md "Session
  // 15"). Every start of the benchmark's 77 default-model runs ends at 0.57 or more, so none of
  // them searches more than before.
  double forearm_start_weak_energy = 0.5;
  // Plausibility: the hand centre must lie at least `min_camera_depth` (m) in front of every
  // camera and inside the image of at least `min_cameras_for_start` cameras; a pose that is not is
  // never reported (the frame is lost).
  double min_camera_depth = 0.05;
  // Live graphs (issue 12): the start and re-detection searches (the hypotheses above) take tens of
  // milliseconds, which on the frame path is a latency spike. With asynchronous_search the set
  // that needs one hands the tracking over to a worker thread: a copy of the tracker, as it was
  // before that set, tracks it synchronously (search included) and then every set that arrives
  // meanwhile, in order, until it has caught up; the update that finds it idle adopts its state,
  // which is then exactly the synchronous tracker's. The frame path meanwhile only tracks as
  // usual (a set without a live track is reported without a pose) and never searches, so its
  // work per set is one ordinary step. Offline tools keep it off: their results then do not
  // depend on thread timing.
  bool asynchronous_search = false;
  // The nice value above the frame path's of a worker that re-detects while the frame path has a
  // live track: on a machine with as many busy threads as cores (five segmentations, the tracker, a
  // renderer or drivers), an equal-priority worker's search delays the frame path by its whole
  // length; lowered, it runs in what is left. A worker started for a set without a pose (no track,
  // or lost) keeps the frame path's priority: the sets wait for it, and the frame path has little
  // to do meanwhile. 0: equal.
  int worker_niceness = 10;
  // Threads for one hypothesis search (its candidates are scored and refined independently; the
  // result is the same for any number). The live graph's worker uses the cores the frame path
  // leaves free while a start keeps the sets waiting (issue 12); offline tools keep one thread, so
  // that their frames per second measure one core. New threads take the searching thread's nice
  // value.
  int search_threads = 1;
  // Catch-up (issue 12): with asynchronous_search, the sets the worker has not tracked yet are
  // kept for it only while they are within `catch_up_seconds` (by stamp) of the newest set (at
  // most kMaxCatchUpFrames; older ones are skipped, as a synchronous tracker skips a camera set
  // that never came). A set that the frame path reported without a pose and the worker tracked
  // comes back as a late result (HandTracker::takeLateResults; takeReadyLateResults as soon as the
  // worker has it). 0: only the newest set is kept, and no late results.
  double catch_up_seconds = 0.25;
  // The model's colours learnt from the frames it tracks well (colour_adaptation.h); reset() and
  // setModel() go back to the model's own. Not for a model whose colours were fitted to the user
  // (HandModel::colours_fitted). With the colours a calibration routine gives (the
  // issue 10 fit without its shape search) the benchmark's pooled error fell from 16.4 to 15.4 mm
  // and its rolled-over frames from 0.8 to 0.1 % (session 8): a skin far from the model's colour
  // weakens the overlap of the parts that differ most, and the thumb's side with them.
  ColourAdaptationParams colour_adaptation;
};
// The most sets the catch-up keeps, whatever their stamps say.
constexpr int kMaxCatchUpFrames = 120;

// The angle (radians) between two orientations' wrist->middle-knuckle axes (x) and between their
// back-of-hand normals (z). A flip in the sense of TrackerParams: either is above 90 degrees.
double knuckleAxisAngle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);
double palmNormalAngle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);
bool isFlip(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);

// The start prior (TrackerParams::start_facing_margin) on start candidates sorted best first:
// moves to the front the candidate that is rolled over relative to the best one, has an energy
// within `margin` of it, and turns the back of the hand more towards the cameras of
// `observations` (the sum over cameras of the cosine between the back-of-hand normal and the
// direction to the camera); the order is otherwise kept. margin <= 0: unchanged.
void preferBackFacingCameras(const std::vector<CameraObservation>& observations, double margin,
                             std::vector<OptimizationResult>* candidates);

// The forearm cue (TrackerParams::min_arm_cells): per camera with sleeve evidence, the cosine
// between the projected wrist->middle-knuckle direction and the direction from the sleeve's
// centroid to the hand foreground's, weighted by the projected length (cameras the hand points
// at have little say). Empty when no camera has evidence. +1: the wrist is on the arm's side.
std::optional<double> forearmVote(const Pose& pose,
                                  const std::vector<CameraObservation>& observations,
                                  int min_arm_cells);

// `rotation` turned back towards `reference` so that it is at most `max_angle` (radians) from it
// (unchanged when it already is, or when max_angle <= 0).
Eigen::Matrix3d boundedRotation(const Eigen::Matrix3d& reference, const Eigen::Matrix3d& rotation,
                                double max_angle);

// The periodic re-detection's decision, given the tracked result of this frame and the start
// routine's candidates (best first), both poses of `model`: `adopt` indexes the candidate that
// replaces the track (the first that is no flip of it, better by redetect_margin, or by
// flip_margin when it turned by redetect_turn_angle or curled by redetect_flexion_change), `carry`
// the flipped candidate that starts being carried as the alternative (the best flip, when it beats
// the adopted candidate, or else the track, by flip_margin; while one is carried, only together
// with an adoption, which replaces it); -1: none. A flip is never adopted here, whatever its
// margin, unless it returns to an orientation of `recent` (the track's last frames, oldest first)
// of which the track itself is a flip (TrackerParams::flip_return_frames): that one counts as no
// flip.
struct RedetectionChoice {
  int adopt = -1;
  int carry = -1;
};
RedetectionChoice chooseRedetection(const HandModel& model, const OptimizationResult& tracked,
                                    const std::vector<OptimizationResult>& candidates,
                                    const TrackerParams& params, bool carrying,
                                    const std::vector<Eigen::Matrix3d>& recent = {});

// The carried flip on one frame (TrackerParams::flip_margin): its energy and the track's, both
// optimised on this frame; `wins` and `frames` (the alternative's counts so far) are updated.
// kDrop: not above the track by flip_keep_margin, or flip_max_frames carried without confirming;
// kConfirm: its flip_confirm_frames-th win (above the track by flip_margin), it replaces the track.
enum class AlternativeVerdict { kKeep, kConfirm, kDrop };
AlternativeVerdict judgeAlternative(double track_energy, double challenger_energy,
                                    const TrackerParams& params, int* wins, int* frames);

// Whether a bare forearm may be in the frame of `energy` (TrackerParams::forearm_start_gain): the
// forearm, straight on from the palm, adds more than `min_gain` to the energy at `pose` or at the
// open hand reversed about its centre (fingers where its wrist is).
bool forearmMayBeBare(const HandModel& model, const PoseEnergy& energy, const Pose& pose,
                      double min_gain);

// Honesty (TrackerParams::min_camera_depth): the hand centre is in front of every camera and
// inside the image of at least `min_cameras` of them.
bool isPlausiblePose(const Pose& pose, const std::vector<CameraObservation>& observations,
                     double min_camera_depth, int min_cameras);

struct FrameResult {
  double stamp = 0.0;
  std::int64_t frame_id = 0;  // update's frame_id: the caller's identity of the set
  // A catch-up result (TrackerParams::catch_up_seconds): an earlier update reported this set
  // without a pose while a worker had the search; this is the worker's pose for it.
  bool late = false;
  TrackStatus status = TrackStatus::kWaiting;
  bool has_pose = false;  // false while waiting: pose and fingertips are then meaningless
  Pose pose;
  Fingertips fingertips;
  EnergyTerms energy;
  int num_cameras = 0;
  bool restarted = false;  // the track had been lost and was started again in this frame
  bool flipped = false;    // a confirmed flip hypothesis replaced the track in this frame
};

class HandTracker {
 public:
  HandTracker(const HandModel& model, const TrackerParams& params);
  // A pending worker (TrackerParams::asynchronous_search) is stopped after its current set; a
  // moved tracker takes its worker along.
  ~HandTracker();
  HandTracker(HandTracker&&) noexcept;
  HandTracker& operator=(HandTracker&&) noexcept;

  // One synchronized set: the cameras that delivered, each with its foreground image SoG
  // (undistorted pixels). Missing cameras are simply absent. `frame_id` identifies the set in the
  // results (FrameResult::frame_id; the live graph passes its stamp in ns).
  FrameResult update(const std::vector<CameraObservation>& observations, double stamp,
                     std::int64_t frame_id = 0);
  // The late results collected by the last update (TrackerParams::catch_up_seconds), oldest
  // first, all of sets before that update's own; moved out (the next update replaces them).
  std::vector<FrameResult> takeLateResults();
  // Between updates: the late results the worker has found since the last update or call, oldest
  // first, so that they need not wait for the next set (the live graph publishes them as they
  // come); the worker goes on.
  std::vector<FrameResult> takeReadyLateResults();
  // Called on the worker's thread each time it has found the pose of a set reported without one:
  // takeReadyLateResults then has a late result. It must return at once and not call the tracker
  // (it only signals the thread that does); kept through reset, setModel and setParams, and given
  // to the workers started from then on.
  void setLateResultCallback(std::function<void()> callback) {
    late_result_callback_ = std::move(callback);
  }

  void reset();
  // The next update runs the re-detection (the start routine, its result adopted as a periodic
  // re-detection's is) whatever redetect_interval, when it tracks a pose then; reset forgets the
  // request. The front ends ask for it on the first set segmented in a started hand's region
  // (PipelineParams::redetect_in_started_region).
  void requestRedetection() { redetection_requested_ = true; }
  // Takes over `other`'s track (a trial start on the same model: one of a still scene's
  // hypotheses, startOnStillScene): its pose and motion history, the flip hypothesis it carries and
  // its learnt colours; this tracker's parameters and late-result callback stay. A search this
  // tracker's worker runs is dropped, as by reset.
  void adoptTrack(const HandTracker& other);
  // Switches to another model of the same hand (a fitted one, issue 10) and keeps tracking from
  // the current pose (joints clamped to the new limits); a pending search, the carried
  // alternative and the similarity reference are dropped, since they belong to the old model.
  void setModel(const HandModel& model);
  // The worker (TrackerParams::asynchronous_search) has not been adopted yet.
  bool searching() const { return worker_ != nullptr; }
  // Blocks until the worker (if any) has tracked every set handed to it; the next update adopts it.
  void waitForSearch() const;
  // Tests: every worker started from now on waits for `gate` before it starts, so that a test
  // decides how many sets arrive while it runs.
  void holdSearchesUntil(std::shared_future<void> gate) { search_gate_ = std::move(gate); }
  // Sets handed to the worker that it has not tracked yet.
  int keptFrames() const;
  const HandModel& model() const { return model_; }
  // The model's size against the one it was made with (TrackerParams::size_step).
  double sizeFactor() const { return size_factor_; }
  const TrackerParams& params() const { return params_; }
  // New parameters (the energy rebuilt); with colour_adaptation off, the model's own colours again.
  void setParams(const TrackerParams& params);

 private:
  // Automatic start: triangulate the foreground, score open-hand orientation hypotheses there,
  // refine the best few. Returns the refined candidates, best first (plausible ones only, and
  // none that the forearm cue calls reversed); empty when too few cameras see the hand or the
  // foreground cannot be triangulated in front of them.
  // `current`: the tracked pose, also refined as a candidate.
  static std::vector<OptimizationResult> startFromHypotheses(
      const HandModel& model, const TrackerParams& params, const PoseEnergy& energy,
      const std::vector<CameraObservation>& observations, const std::optional<Pose>& current);
  // The search for this frame with `search_params` (the tracker's, but for the forearm cue): the
  // candidates, best first; or, with asynchronous_search, none (the set is handed to a worker
  // after this step, see update).
  std::optional<std::vector<OptimizationResult>> hypothesisSearch(
      const PoseEnergy& energy, const std::vector<CameraObservation>& observations,
      const TrackerParams& search_params);
  // The tracking of one set (update without the worker).
  FrameResult step(const std::vector<CameraObservation>& observations, double stamp);
  bool armSaysReversed(const Pose& pose, const std::vector<CameraObservation>& observations) const;
  bool plausible(const Pose& pose, const std::vector<CameraObservation>& observations) const;
  // The pose the optimiser starts from: `current` moved on at the velocity from `previous`
  // (absent: `current`), its turn capped at max_rotation_per_frame.
  Pose predictedPose(const std::optional<Pose>& previous, const Pose& current) const;
  // Pulls `result` back to at most max_rotation_change_per_frame from the prediction's orientation
  // and max_rotation_per_frame from the current one (re-scored when it moved).
  void boundRotation(const PoseEnergy& energy, const Pose& current, const Pose& predicted,
                     OptimizationResult* result) const;
  bool looksLost(double similarity) const;
  // TrackerParams::colour_adaptation, after the step that gave `result`.
  void adaptColours(const FrameResult& result, const std::vector<CameraObservation>& observations);
  // The model's colours set to `colours` (empty: its start colours), the energy rebuilt with them.
  void setColours(const std::vector<Hsv>& colours);
  // Drops what colour_adaptation learnt: its samples, and the model's own colours again.
  void forgetLearntColours();
  // The warm-started optimisation of a frame from `current` (and the turn since `previous`):
  // from the prediction, bounded (boundRotation), and with counter_turn_start also from the
  // counter-turned prediction; the better result.
  OptimizationResult trackFromPrediction(const PoseEnergy& energy,
                                         const std::optional<Pose>& previous,
                                         const Pose& current) const;
  // TrackerParams::toggle_silhouette_weight: tries each straight long finger curled and each
  // curled one open, and keeps the best toggle that raises E + w D, on a track that does not look
  // lost. Returns whether result->pose was replaced.
  // `silhouette`: the frame's scorer, made here when first needed (adaptSize uses it too).
  bool toggleFingers(const PoseEnergy& energy, const std::vector<CameraObservation>& observations,
                     OptimizationResult* result, std::optional<SilhouetteScorer>* silhouette) const;
  // TrackerParams::curled_refine_*: refines the long fingers of a curled hand, the root and the
  // thumb held, with occlusion and the model's area; `energy` is left as it was. Returns whether
  // it refined; then result->energy is not the refined pose's (the caller scores it).
  bool refineCurledFingers(PoseEnergy& energy, OptimizationResult* result) const;
  // TrackerParams::size_step: after a held frame `result`, may scale model_ (and rebuild the
  // energy for the next frame).
  // `silhouette`: the frame's scorer (toggleFingers), made here if the toggles did not.
  void adaptSize(const FrameResult& result, const std::vector<CameraObservation>& observations,
                 std::optional<SilhouetteScorer>* silhouette);
  // model_ at `size` times base_model_'s lengths (scaleHandModel), its colours kept; the energy
  // rebuilt. Always from base_model_, so that a size reached by any path is the same model.
  void setSize(double size);
  // Refines the forearm's direction for result->pose from `from` (empty: straight on from the
  // palm) and scores the result with it; returns the direction.
  Eigen::Vector3d fitForearm(const PoseEnergy& energy, OptimizationResult* result,
                             const std::optional<Eigen::Vector3d>& from) const;
  // hypothesisSearch with the forearm straight on from the palm, and without the sleeve's forearm
  // cue while the forearm is in the energy.
  std::optional<std::vector<OptimizationResult>> searchWithForearm(
      PoseEnergy& energy, const std::vector<CameraObservation>& observations);
  // A start without a track and without the forearm (a synchronous search): the search is run
  // again with the forearm, and its candidates replace `candidates` (and the forearm stays on)
  // when its best one gains more than forearm_min_gain by it. The first start on a bare forearm
  // otherwise has only the hand-only energy and the sleeve cue, which on a flexed wrist can pick
  // a reversed hand that the forearm's gain at that pose never corrects.
  // The cheap test before that second search: forearmMayBeBare.
  void startWithForearmIfItIsBare(PoseEnergy& energy,
                                  const std::vector<CameraObservation>& observations,
                                  std::vector<OptimizationResult>* candidates);
  // Decides forearm_present_ for the next frame from the reported pose (its energy `energy_now`
  // with the frame's forearm state) (TrackerParams::forearm_min_gain).
  void updateForearmPresence(PoseEnergy& energy, const Pose& pose,
                             const std::optional<Eigen::Vector3d>& direction, double energy_now);

  // The flip hypothesis being carried (see TrackerParams::flip_margin) and its own history.
  struct Alternative {
    std::optional<Pose> previous;
    Pose current;
    int wins = 0;
    int frames = 1;  // carried frames, the one it was found on included
  };
  // Everything step() carries from one set to the next: what the worker starts from and what the
  // frame path adopts from it.
  struct TrackState {
    std::optional<Pose> previous;
    std::optional<Pose> current;
    bool lost = false;
    double typical_similarity = 0.0;
    int frames_since_start = 0;
    int frames_since_redetection = 0;
    std::optional<Alternative> alternative;
    int arm_reversed_streak = 0;
    bool forearm_present = false;
    std::optional<Eigen::Vector3d> forearm;
    std::optional<Eigen::Vector3d> alternative_forearm;
    std::vector<Eigen::Matrix3d> recent_rotations;
    // TrackerParams::colour_adaptation: tracked frames without a start, flip or alternative; the
    // sampled frames since the colours were last updated; the samples; the model's colours (empty,
    // as in a fresh state: its start colours).
    int tracked_streak = 0;
    int colour_samples = 0;
    GaussianColourStatistics colour_statistics;
    std::vector<Hsv> colours;
    // TrackerParams::size_step: the model's size against the one the tracker was made with, and
    // the held frames until the next trial.
    double size_factor = 1.0;
    int frames_to_size_trial = 0;
  };
  TrackState trackState() const;
  void setTrackState(const TrackState& state);
  static bool sameTrackState(const TrackState& a, const TrackState& b);

  // The worker of asynchronous_search (defined in tracker.cpp).
  struct Worker;
  // Starts a worker from `state` (the state before `frame`'s step) with `frame` as its first set,
  // its thread's nice value raised by `niceness`.
  struct HandedFrame;
  void startWorker(const TrackState& state, HandedFrame frame, int niceness);
  // Hands a set the frame path has stepped to the worker, within the catch-up's bounds.
  void handToWorker(HandedFrame frame);
  // Moves the worker's results for sets the frame path reported without a pose into the late
  // results; with `adopt` (the worker is idle), also takes its state and ends it.
  void collectWorker(bool adopt);
  void stopWorker();

  HandModel model_;
  HandModel base_model_;  // the model the tracker was made with (setModel), at size 1
  TrackerParams params_;
  PoseEnergy energy_;  // the frame's energy; rebuilt only when the parameters change
  std::array<LongFingerJoints, kNumFingers - 1> finger_joints_;  // of model_ (toggleFingers)
  std::vector<int> thumb_joints_;                                // of model_ (refineCurledFingers)
  std::optional<Pose> previous_;
  std::optional<Pose> current_;
  bool lost_ = false;
  double typical_similarity_ = 0.0;  // running average while tracking (0: none yet)
  // Frames since the track's pose came from the start routine (a start, or a re-detection adopted
  // in its place): the toggles wait for toggle_min_track_frames of them. Frames since the last
  // periodic re-detection (or start): redetect_interval counts these; a re-detection that keeps
  // the track does not make its fingers the search's.
  int frames_since_start_ = 0;
  int frames_since_redetection_ = 0;
  bool redetection_requested_ = false;  // requestRedetection, for the next update
  std::optional<Alternative> alternative_;
  // The forearm's world direction (EnergyParams::forearm_gaussians) of the track and of the
  // carried alternative, refined every frame; empty: straight on from the palm.
  bool forearm_present_ = false;
  std::optional<Eigen::Vector3d> forearm_;
  std::optional<Eigen::Vector3d> alternative_forearm_;
  int arm_reversed_streak_ = 0;
  // The track's orientations over its last frames since a start or flip, oldest first.
  std::vector<Eigen::Matrix3d> recent_rotations_;
  // TrackerParams::colour_adaptation (TrackState; the learnt colours are model_'s);
  // start_colours_: the model's own.
  int tracked_streak_ = 0;
  int colour_samples_ = 0;
  GaussianColourStatistics colour_statistics_;
  std::vector<Hsv> start_colours_;
  // TrackerParams::size_step: model_'s size against the one it was made with, and the held frames
  // until the next trial.
  double size_factor_ = 1.0;
  int frames_to_size_trial_ = 0;
  // asynchronous_search: step() asked for a search; update then hands the set to a worker.
  bool search_wanted_ = false;
  std::unique_ptr<Worker> worker_;
  std::unique_ptr<Worker> retired_;  // adopted, its thread still ending
  std::vector<FrameResult> late_results_;
  std::shared_future<void> search_gate_;
  std::function<void()> late_result_callback_;
};

}  // namespace sag_hand_tracker

// gtest checker of the tracker's live calibration service ~calibrate (rostest helper,
// calibrate_service.test: the demo graph playing the studio's calibration_routine in a loop).
//   - bad requests (duration 0, negative, too long, NaN; save_path relative, in a missing folder,
//     an existing file) are refused at once with a message naming the problem, and write nothing;
//   - a call too short for the routine fails with the routine check's complaints and no file;
//   - of two calls of `duration` seconds with save paths, the second made while the first
//     collects, exactly one is refused at once (no file) and the other succeeds: its file loads as
//     a model with the response's bone lengths, the tracker keeps processing sets during the fit
//     and publishes joint_states after the switch, and its status names the saved model.
// Private parameters: service (/tracker/calibrate), duration (7 s), short_duration (1 s),
//   wait_for_service (60 s), wait_for_tracking (60 s), call_timeout (200 s: wall limit of the
//   successful call), after_switch (30 s: wall limit to see min_joint_states after the switch),
//   min_joint_states (10), min_status_while_fitting (5).
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <stdlib.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <future>
#include <limits>
#include <mutex>
#include <string>
#include <vector>

#include "sag_hand_tracker/Calibrate.h"
#include "sag_hand_tracker/SkinGate.h"
#include "sag_hand_tracker/TrackingStatus.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/segmentation/background_plate.h"

namespace {

namespace fs = std::filesystem;
using sag_hand_tracker::Calibrate;
using sag_hand_tracker::TrackingStatus;

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// Everything the checker hears from the tracker, with the wall time of the last arrivals.
struct Observed {
  std::mutex mutex;
  long joint_states = 0;
  long status_while_fitting = 0;
  long joint_states_while_fitting = 0;
  std::string calibration;  // the last status' calibration field
  std::string model;        // the last status' model field
  // The skin gates on cam0/skin_gate (latched): none for the built-in model, whose colours are
  // not the user's; the fitted model's after the switch.
  std::vector<sag_hand_tracker::SkinGate> skin_gates;
};

class CalibrateChecker : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    spinner_ = new ros::AsyncSpinner(2);
    spinner_->start();
    ros::NodeHandle nh, pnh("~");
    service_name_ = pnh.param<std::string>("service", "/tracker/calibrate");
    observed_ = new Observed;
    joint_sub_ = new ros::Subscriber(nh.subscribe("joint_states", 50, &onJointState));
    status_sub_ = new ros::Subscriber(nh.subscribe("status", 50, &onStatus));
    skin_gate_sub_ = new ros::Subscriber(nh.subscribe("cam0/skin_gate", 5, &onSkinGate));
    char pattern[] = "/tmp/sag_calibrate_checker_XXXXXX";
    const char* dir = ::mkdtemp(pattern);
    ASSERT_NE(dir, nullptr);
    dir_ = dir;
    service_ready_ = ros::service::waitForService(
        service_name_, ros::Duration(pnh.param("wait_for_service", 60.0)));
  }

  static void onJointState(const sensor_msgs::JointState::ConstPtr&) {
    std::lock_guard<std::mutex> lock(observed_->mutex);
    ++observed_->joint_states;
    if (observed_->calibration.rfind("fitting", 0) == 0) ++observed_->joint_states_while_fitting;
  }

  static void onStatus(const TrackingStatus::ConstPtr& msg) {
    std::lock_guard<std::mutex> lock(observed_->mutex);
    observed_->calibration = msg->calibration;
    observed_->model = msg->model;
    if (msg->calibration.rfind("fitting", 0) == 0) ++observed_->status_while_fitting;
  }

  static void onSkinGate(const sag_hand_tracker::SkinGate::ConstPtr& msg) {
    std::lock_guard<std::mutex> lock(observed_->mutex);
    observed_->skin_gates.push_back(*msg);
  }

  static void TearDownTestSuite() {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
    delete joint_sub_;
    delete status_sub_;
    delete skin_gate_sub_;
    spinner_->stop();
  }

  void SetUp() override { ASSERT_TRUE(service_ready_) << service_name_ << " never appeared"; }

  static Calibrate call(double duration, const std::string& save_path) {
    Calibrate srv;
    srv.request.duration = duration;
    srv.request.save_path = save_path;
    EXPECT_TRUE(ros::service::call(service_name_, srv)) << "the call itself failed";
    std::printf("calibrate_checker: duration %g, save_path '%s' -> success %d: %s\n", duration,
                save_path.c_str(), srv.response.success, srv.response.message.c_str());
    return srv;
  }

  // Waits (wall clock) until `condition` holds, at most `seconds`.
  template <typename Condition>
  static bool waitFor(double seconds, Condition condition) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end && ros::ok()) {
      {
        std::lock_guard<std::mutex> lock(observed_->mutex);
        if (condition(*observed_)) return true;
      }
      ros::WallDuration(0.05).sleep();
    }
    return false;
  }

  static inline ros::AsyncSpinner* spinner_ = nullptr;
  static inline ros::Subscriber* joint_sub_ = nullptr;
  static inline ros::Subscriber* status_sub_ = nullptr;
  static inline ros::Subscriber* skin_gate_sub_ = nullptr;
  static inline Observed* observed_ = nullptr;
  static inline std::string service_name_;
  static inline std::string dir_;
  static inline bool service_ready_ = false;
};

TEST_F(CalibrateChecker, BadRequestsAreRefusedAtOnceWithoutAFile) {
  const std::string path = dir_ + "/bad.yaml";
  for (double duration : {0.0, -2.0, 31.0, std::numeric_limits<double>::quiet_NaN()}) {
    const Calibrate srv = call(duration, path);
    EXPECT_FALSE(srv.response.success);
    EXPECT_TRUE(contains(srv.response.message, "duration must be in (0, 30]"))
        << srv.response.message;
    EXPECT_LT(srv.response.seconds, 1.0) << "refused only after collecting";
  }
  {
    const Calibrate srv = call(3.0, dir_ + "/no_such_folder/fitted.yaml");
    EXPECT_FALSE(srv.response.success);
    EXPECT_TRUE(contains(srv.response.message, "does not exist")) << srv.response.message;
    EXPECT_FALSE(fs::exists(dir_ + "/no_such_folder"));
  }
  {
    const Calibrate srv = call(3.0, "relative/fitted.yaml");
    EXPECT_FALSE(srv.response.success);
    EXPECT_TRUE(contains(srv.response.message, "not an absolute path")) << srv.response.message;
  }
  {
    const std::string existing = dir_ + "/existing.yaml";
    { std::ofstream(existing) << "not a model\n"; }
    const Calibrate srv = call(3.0, existing);
    EXPECT_FALSE(srv.response.success);
    EXPECT_TRUE(contains(srv.response.message, "the file exists")) << srv.response.message;
    std::ifstream file(existing);
    std::string content;
    std::getline(file, content);
    EXPECT_EQ(content, "not a model") << "the existing file was changed";
    fs::remove(existing);
  }
  EXPECT_FALSE(fs::exists(path));
  EXPECT_TRUE(fs::is_empty(dir_)) << "a refused call left a file (temporary?) in " << dir_;
}

TEST_F(CalibrateChecker, TooShortForTheRoutineFailsWithItsComplaintsAndNoFile) {
  ros::NodeHandle pnh("~");
  ASSERT_TRUE(waitFor(pnh.param("wait_for_tracking", 60.0), [](const Observed& o) {
    return o.joint_states > 0;
  })) << "the tracker never published joint_states";
  const std::string path = dir_ + "/short.yaml";
  const Calibrate srv = call(pnh.param("short_duration", 1.0), path);
  EXPECT_FALSE(srv.response.success);
  EXPECT_GT(srv.response.sets, 0);
  EXPECT_TRUE(contains(srv.response.message, "do not show the calibration routine"))
      << srv.response.message;
  EXPECT_TRUE(contains(srv.response.message, "the fit needs 2.0 s") ||
              contains(srv.response.message, "no frame with the hand"))
      << srv.response.message;
  EXPECT_FALSE(fs::exists(path));
  EXPECT_TRUE(fs::is_empty(dir_)) << "a failed call left a file in " << dir_;
}

TEST_F(CalibrateChecker, FitsSwitchesSavesAndRefusesASecondCall) {
  ros::NodeHandle pnh("~");
  ASSERT_TRUE(waitFor(pnh.param("wait_for_tracking", 60.0), [](const Observed& o) {
    return o.joint_states > 0;
  })) << "the tracker never published joint_states";
  {
    std::lock_guard<std::mutex> lock(observed_->mutex);
    EXPECT_TRUE(observed_->skin_gates.empty()) << "a skin gate from the built-in model's colours";
  }
  const double duration = pnh.param("duration", 7.0);
  const double call_timeout = pnh.param("call_timeout", 200.0);
  // Two calls, the second made once a collection runs. Which one the tracker takes first is not
  // known here (the status may still say "collecting" from the short call): exactly one of them
  // must be refused at once, and the other one fits.
  const std::string first_path = dir_ + "/first.yaml", second_path = dir_ + "/second.yaml";
  std::future<Calibrate> first =
      std::async(std::launch::async, [&] { return call(duration, first_path); });
  ASSERT_TRUE(waitFor(10.0, [](const Observed& o) { return o.calibration == "collecting"; }))
      << "the status never said 'collecting'";
  std::future<Calibrate> second =
      std::async(std::launch::async, [&] { return call(duration, second_path); });
  for (std::future<Calibrate>* call : {&first, &second}) {
    ASSERT_EQ(call->wait_for(std::chrono::duration<double>(call_timeout)),
              std::future_status::ready)
        << "a calibration did not answer within " << call_timeout << " s";
  }
  const Calibrate first_srv = first.get(), second_srv = second.get();
  auto refused = [](const Calibrate& srv) {
    return !srv.response.success && contains(srv.response.message, "already running");
  };
  ASSERT_NE(refused(first_srv), refused(second_srv))
      << "exactly one of two concurrent calls must be refused; first: "
      << first_srv.response.message << "; second: " << second_srv.response.message;
  const bool first_won = refused(second_srv);
  const Calibrate& srv = first_won ? first_srv : second_srv;
  const Calibrate& loser = first_won ? second_srv : first_srv;
  const std::string path = first_won ? first_path : second_path;
  EXPECT_LT(loser.response.seconds, 1.0) << "the refusal waited";
  EXPECT_FALSE(fs::exists(first_won ? second_path : first_path));
  ASSERT_TRUE(srv.response.success) << srv.response.message;

  // The response describes the fit.
  EXPECT_GT(srv.response.frames_used, 0);
  EXPECT_GE(srv.response.tracked_frames, srv.response.frames_used);
  EXPECT_GE(srv.response.sets, srv.response.tracked_frames);
  EXPECT_EQ(srv.response.saved_path, path);
  for (double value : {srv.response.energy_before, srv.response.energy_after,
                       srv.response.score_before, srv.response.score_after}) {
    EXPECT_TRUE(std::isfinite(value));
  }
  EXPECT_GT(srv.response.score_after, 0.0);
  for (double factor : {srv.response.scale, srv.response.palm_width, srv.response.finger_length,
                        srv.response.thickness}) {
    EXPECT_GE(factor, 0.6);
    EXPECT_LE(factor, 1.6);
  }

  // The file is an ordinary model with the fitted bones.
  ASSERT_TRUE(fs::exists(path));
  sag_hand_tracker::HandModel model;
  ASSERT_NO_THROW(model = sag_hand_tracker::loadHandModel(path));
  ASSERT_EQ(model.bones.size(), srv.response.bone_lengths.size());
  ASSERT_EQ(srv.response.bone_names.size(), srv.response.bone_lengths.size());
  for (size_t b = 0; b < model.bones.size(); ++b) {
    EXPECT_EQ(model.bones[b].name, srv.response.bone_names[b]);
    EXPECT_NEAR(model.bones[b].length, srv.response.bone_lengths[b],
                1e-5 * srv.response.bone_lengths[b] + 1e-9)
        << model.bones[b].name;
  }
  for (const fs::directory_entry& entry : fs::directory_iterator(dir_)) {
    EXPECT_EQ(entry.path().string(), path) << "a leftover file";
  }

  // Tracking went on during the fit, and goes on with the fitted model.
  long joint_states_at_switch = 0;
  {
    std::lock_guard<std::mutex> lock(observed_->mutex);
    joint_states_at_switch = observed_->joint_states;
    std::printf(
        "calibrate_checker: during the fit %ld statuses and %ld joint_states; call %.1f s\n",
        observed_->status_while_fitting, observed_->joint_states_while_fitting,
        srv.response.seconds);
    EXPECT_GE(observed_->status_while_fitting, pnh.param("min_status_while_fitting", 5))
        << "the tracker stopped processing sets while the fit ran";
  }
  const long wanted = pnh.param("min_joint_states", 10);
  EXPECT_TRUE(
      waitFor(pnh.param("after_switch", 30.0),
              [&](const Observed& o) { return o.joint_states >= joint_states_at_switch + wanted; }))
      << "fewer than " << wanted << " joint_states after the switch";
  EXPECT_TRUE(waitFor(5.0, [&](const Observed& o) { return o.model == path; }))
      << "the status does not name the saved model";
  // The segmentations get the skin gate around the fitted model's colours.
  EXPECT_TRUE(waitFor(5.0, [&](const Observed& o) { return !o.skin_gates.empty(); }))
      << "no skin gate on cam0/skin_gate after the calibration";
  std::lock_guard<std::mutex> lock(observed_->mutex);
  EXPECT_EQ(observed_->calibration.rfind("fitted: ", 0), 0u) << observed_->calibration;
  if (!observed_->skin_gates.empty()) {
    const sag_hand_tracker::SkinGate& gate = observed_->skin_gates.back();
    EXPECT_EQ(gate.source, path);
    const sag_hand_tracker::SkinParams expected = sag_hand_tracker::personalSkinGate(model);
    EXPECT_NEAR(gate.hue_min_deg, expected.hue_min_deg, 1e-3);
    EXPECT_NEAR(gate.hue_max_deg, expected.hue_max_deg, 1e-3);
    EXPECT_NEAR(gate.value_min, expected.value_min, 1e-4);
  }
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "calibrate_checker");
  ros::NodeHandle nh;  // keeps the node up for the whole run
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}

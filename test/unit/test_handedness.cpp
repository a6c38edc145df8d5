// decideHandedness's edges; which hand the images choose is tested end to end on studio bags
// (TrackBagTool.TrackBagTellsALeftHandFromARightOne).
#include <gtest/gtest.h>

#include "sag_hand_tracker/tracking/handedness.h"
#include "test_support/rendered_scene.h"
#include "test_support/synthetic_scene.h"

using namespace sag_hand_tracker;

TEST(Handedness, BadParametersAreNamed) {
  HandednessParams params;
  params.decision_sets = 0;
  EXPECT_THROW(validate(params), InputError);
  params = HandednessParams();
  params.close_margin = -1.0;
  EXPECT_THROW(validate(params), InputError);
  params = HandednessParams();
  params.max_sets = params.decision_sets - 1;
  try {
    validate(params);
    FAIL() << "max_sets below decision_sets accepted";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("max_sets"), std::string::npos) << error.what();
  }
}

TEST(Handedness, WithoutSetsTheModelsOwnHandStaysAndTheTextSaysWhy) {
  const HandModel left = loadHandModel(sag_test::modelPath("sag"), Handedness::kLeft);
  const HandednessDecision decision = decideHandedness(
      left, sag_test::renderedRig(), PipelineParams(), [](FrameSet*) { return false; });
  EXPECT_FALSE(decision.decided);
  EXPECT_EQ(decision.hand, Handedness::kLeft);
  EXPECT_EQ(decision.sets, 0);
  EXPECT_EQ(handednessText(decision), "left (the model's own: no set where both hands had a pose)");
}

TEST(Handedness, TheTextNamesTheChoiceAndItsMargin) {
  HandednessDecision decision;
  decision.decided = true;
  decision.hand = Handedness::kLeft;
  decision.sets = 25;
  decision.right_energy = 0.6624;
  decision.left_energy = 0.6831;
  decision.median_difference = -0.0213;
  decision.right_higher = 2;
  EXPECT_EQ(handednessText(decision),
            "left (higher than a right hand in 23 of 25 sets, by 0.0213 in the median; mean "
            "energy 0.683 against 0.662)");
  decision.hand = Handedness::kRight;
  decision.median_difference = 0.0004;
  decision.right_higher = 14;
  decision.close = true;
  EXPECT_EQ(handednessText(decision),
            "right (higher than a left hand in 14 of 25 sets, by 0.0004 in the median; mean "
            "energy 0.662 against 0.683; close: give --hand if you know)");
}

#include <gtest/gtest.h>

#include <sstream>

#include "sag_hand_tracker/apps/progress.h"

using namespace sag_hand_tracker;

TEST(Progress, ProgressRendersBarAndPercent) {
  EXPECT_EQ(ProgressBar::render(0.0, "start", 10), "[          ]   0% start");
  EXPECT_EQ(ProgressBar::render(0.5, "", 10), "[#####     ]  50%");
  EXPECT_EQ(ProgressBar::render(1.0, "done", 4), "[####] 100% done");
  EXPECT_EQ(ProgressBar::render(7.0, "x", 4), "[####] 100% x");  // clamped
  EXPECT_EQ(ProgressBar::render(-1.0, "x", 4), "[    ]   0% x");
}

TEST(Progress, ProgressWritesOneLinePerTenthWhenNotInteractive) {
  std::ostringstream out;
  {
    ProgressBar bar(out, false);
    for (int i = 0; i <= 100; ++i) bar.update(i / 100.0, "frame " + std::to_string(i));
    bar.finish("101 frames");
  }
  const std::string text = out.str();
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 12);  // 0 %, 10 %, ..., 100 %, final
  EXPECT_EQ(text.find('\r'), std::string::npos);
  EXPECT_NE(text.find("  50% frame 50\n"), std::string::npos) << text;
  EXPECT_NE(text.find(" 100% frame 100\n"), std::string::npos) << text;
  EXPECT_NE(text.find(" 100% 101 frames\n"), std::string::npos) << text;
}

TEST(Progress, ProgressDoesNotRepeatTheLastLine) {
  std::ostringstream out;
  ProgressBar bar(out, false);
  bar.update(1.0, "done");
  bar.finish("done");
  EXPECT_EQ(out.str(), ProgressBar::render(1.0, "done") + "\n");
}

TEST(Progress, ProgressRedrawsInPlaceWhenInteractive) {
  std::ostringstream out;
  ProgressBar bar(out, true, 0.0);
  bar.update(0.25, "a long status text");
  bar.update(0.5, "short");
  bar.finish("done");
  const std::string text = out.str();
  EXPECT_EQ(std::count(text.begin(), text.end(), '\r'), 3);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1);
  EXPECT_EQ(text.back(), '\n');
  // The shorter line is padded over the longer one before it.
  const std::string second = text.substr(text.find('\r', 1) + 1);
  EXPECT_EQ(second.find(ProgressBar::render(0.5, "short") + "             \r"), 0u) << second;
  bar.update(0.7, "after finish");  // ignored
  EXPECT_EQ(out.str(), text);
}

TEST(Progress, ProgressThrottlesInteractiveRedraws) {
  std::ostringstream out;
  ProgressBar bar(out, true, 3600.0);
  for (int i = 0; i < 50; ++i) bar.update(i / 50.0, "x");
  const std::string text = out.str();
  EXPECT_EQ(std::count(text.begin(), text.end(), '\r'), 1);
  bar.finish("done");  // always drawn
  EXPECT_NE(out.str().find("100% done\n"), std::string::npos);
}

TEST(Progress, ProgressEndsAnUnfinishedInteractiveLine) {
  std::ostringstream out;
  { ProgressBar(out, true, 0.0).update(0.3, "x"); }
  EXPECT_EQ(out.str().back(), '\n');
}

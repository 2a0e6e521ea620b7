// The resolved PSM settings and the warnings for a case file that fixes one
// half of the default drag rule (imb/psm_settings.hpp): the wall-rule
// weighting's Lambda table and the weighting were derived together, so Lambda
// from the file beside that weighting, BGK beside it, or Lambda auto beside
// another weighting each get a warning naming the combination and its
// expected drag error or "no estimate"; the rule's own setting gets none.
// The JSON record (summary.json's "psm") holds every resolved setting.
#include <gtest/gtest.h>

#include <string>

#include "imb/psm_settings.hpp"

using namespace lbdem;

namespace {

imb::PsmSettingsInput rule_input(double d, double tau) {
  imb::PsmSettingsInput in;
  in.q.diameter = d;
  in.q.tau = tau;
  in.q.magic = imb::psm_magic_auto(d, tau);
  in.pipeline = "mapped";
  in.precision = "fp64";
  return in;
}

bool has(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

TEST(PsmSettings, TheRuleItselfHasNoWarningAndAnEstimate) {
  const auto s = imb::resolve_psm_settings(rule_input(10, 0.8));
  EXPECT_TRUE(s.warnings.empty());
  EXPECT_TRUE(s.estimate.known) << s.estimate.reason;
  EXPECT_EQ(s.magic_rule, imb::psm_magic_auto(10, 0.8));
  const std::string js = imb::psm_settings_json(s);
  for (const char* key : {"\"weight\": \"noble_torczynski_wall\"", "\"weight_from\": \"default\"", "\"collision\": \"trt\"",
                          "\"magic_from\": \"rule\"", "\"magic_rule\": ", "\"weight_t\": ", "\"operator\": \"nebb\"",
                          "\"fraction\": \"exact\"", "\"pipeline\": \"mapped\"", "\"precision\": \"fp64\"",
                          "\"tau\": 0.8", "\"diameter\": 10", "\"expected_drag_error\": 0.005", "\"warnings\": 0"})
    EXPECT_TRUE(has(js, key)) << key << "\n" << js;
}

// An old case file: Lambda set, the weighting left to the default.
TEST(PsmSettings, LambdaFromTheFileWithTheRuleWeightingWarns) {
  auto in = rule_input(10, 0.8);
  in.q.magic = 0.25;
  in.magic_from_file = true;
  const auto s = imb::resolve_psm_settings(in);
  ASSERT_EQ(s.warnings.size(), 1u);
  const std::string& w = s.warnings[0];
  EXPECT_TRUE(has(w, "fluid.magic = 0.25 set in the case file with psm.weight = noble_torczynski_wall (the default: "
                     "not set in the file)"))
      << w;
  EXPECT_TRUE(has(w, "no estimate")) << w;
  char rule[64];
  std::snprintf(rule, sizeof rule, "fluid.magic: auto = %.4g", imb::psm_magic_auto(10, 0.8));
  EXPECT_TRUE(has(w, rule)) << w;
  const std::string js = imb::psm_settings_json(s);
  EXPECT_TRUE(has(js, "\"magic_from\": \"file\"")) << js;
  EXPECT_TRUE(has(js, "\"expected_drag_error\": null")) << js;
  EXPECT_TRUE(has(js, "\"warnings\": 1")) << js;
  // The file's Lambda equal to the rule's: the rule's setting, no warning.
  in.q.magic = imb::psm_magic_auto(10, 0.8);
  EXPECT_TRUE(imb::resolve_psm_settings(in).warnings.empty());
}

TEST(PsmSettings, BgkWithTheRuleWeightingWarns) {
  auto in = rule_input(8, 0.9);
  in.q.trt = false;
  in.weight_from_file = true;
  const auto s = imb::resolve_psm_settings(in);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_TRUE(has(s.warnings[0], "fluid.collision = bgk with psm.weight = noble_torczynski_wall:")) << s.warnings[0];
  EXPECT_TRUE(has(imb::psm_settings_json(s), "\"magic_from\": \"bgk\""));
}

TEST(PsmSettings, LambdaAutoWithAnotherWeightingWarns) {
  auto in = rule_input(6, 0.7);
  in.q.weight = imb::PsmWeight::NobleTorczynski;
  in.weight_from_file = true;
  const auto s = imb::resolve_psm_settings(in);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_TRUE(has(s.warnings[0], "fluid.magic: auto (Lambda")) << s.warnings[0];
  EXPECT_TRUE(has(s.warnings[0], "psm.weight = noble_torczynski:")) << s.warnings[0];
  EXPECT_TRUE(has(s.warnings[0], "no estimate")) << s.warnings[0];
  // Both halves of the classic setting named in the file: no warning.
  in.magic_from_file = true;
  in.q.magic = 1e-4;
  EXPECT_TRUE(imb::resolve_psm_settings(in).warnings.empty());
}

}  // namespace

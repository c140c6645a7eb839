// A finished case as the bytes a rank sends to the campaign's writer (encode_case_record) and back:
// every field arrives exactly (NaN angles, signed zeros, subnormals and strings with NUL bytes
// included), and a buffer that is not one whole record is refused instead of read past its end.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "softhom/studies/campaign.hpp"

namespace studies = softhom::studies;

namespace {

studies::CaseRecord sample() {
  studies::CaseRecord r;
  r.id = "ecoflex-circle-a45-vf0.23-square-n16x16-tension";
  r.parameters = {{"matrix", std::string("ecoflex")}, {"angle", std::nan("")}, {"volume_fraction", 0.23},
                  {"resolution", 16.0}, {"load", std::string("a\0b", 3)}};
  r.status = "failed";
  r.error = "the shared load path ended early";
  r.scene_text = "[load]\ntype = \"uniaxial\"\n";
  r.scene_hash = "0123456789abcdef";
  r.columns = {"t_s", "F11", "P11_MPa"};
  r.data = {0.0, 1.0, -0.0, 0.5, 1.25, std::numeric_limits<double>::denorm_min(), 1.0, 1.5, 1e300};
  r.stats = {{"steps", 2.0}, {"wall_time_s", 0.125}, {"volume_fraction_achieved", 0.2299999999999999}};
  r.info = {{"geometry", "4 fibers"}, {"log", ""}, {"warm_start_from", "x"}};
  return r;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

}  // namespace

TEST(CaseRecordCodec, RoundTripIsExact) {
  const studies::CaseRecord r = sample();
  const std::vector<char> bytes = studies::encode_case_record(r);
  const studies::CaseRecord s = studies::decode_case_record(bytes.data(), bytes.size());
  EXPECT_EQ(s.id, r.id);
  ASSERT_EQ(s.parameters.size(), r.parameters.size());
  for (std::size_t i = 0; i < r.parameters.size(); ++i) {
    EXPECT_EQ(s.parameters[i].name, r.parameters[i].name);
    ASSERT_EQ(s.parameters[i].is_string(), r.parameters[i].is_string());
    if (r.parameters[i].is_string()) { EXPECT_EQ(std::get<std::string>(s.parameters[i].value), std::get<std::string>(r.parameters[i].value)); }
    else EXPECT_TRUE(same_bits(std::get<double>(s.parameters[i].value), std::get<double>(r.parameters[i].value)));
  }
  EXPECT_EQ(s.status, r.status);
  EXPECT_EQ(s.error, r.error);
  EXPECT_EQ(s.scene_text, r.scene_text);
  EXPECT_EQ(s.scene_hash, r.scene_hash);
  EXPECT_EQ(s.columns, r.columns);
  ASSERT_EQ(s.data.size(), r.data.size());
  for (std::size_t i = 0; i < r.data.size(); ++i) EXPECT_TRUE(same_bits(s.data[i], r.data[i])) << i;
  EXPECT_EQ(s.stats, r.stats);
  EXPECT_EQ(s.info, r.info);
  EXPECT_EQ(s.rows(), 3u);
}

TEST(CaseRecordCodec, EmptyRecordRoundTrips) {
  const studies::CaseRecord r;
  const auto bytes = studies::encode_case_record(r);
  const auto s = studies::decode_case_record(bytes.data(), bytes.size());
  EXPECT_TRUE(s.id.empty() && s.parameters.empty() && s.data.empty() && s.stats.empty() && s.info.empty());
}

TEST(CaseRecordCodec, TruncatedOrPaddedBufferIsRefused) {
  const auto bytes = studies::encode_case_record(sample());
  // Every proper prefix: a message cut anywhere must throw, never read past the end (ASan would see it).
  for (std::size_t n = 0; n < bytes.size(); ++n)
    EXPECT_THROW(studies::decode_case_record(bytes.data(), n), std::runtime_error) << n;
  std::vector<char> padded = bytes;
  padded.push_back('\0');
  EXPECT_THROW(studies::decode_case_record(padded.data(), padded.size()), std::runtime_error);
  std::vector<char> wrong = bytes;
  wrong[0] ^= 1;  // not a record (the leading magic number)
  EXPECT_THROW(studies::decode_case_record(wrong.data(), wrong.size()), std::runtime_error);
}

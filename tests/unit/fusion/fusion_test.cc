// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/fusion/fusion.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "tests/support/status_matchers.h"

namespace hdrstereo::fusion {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

// Random MRF with data costs in [0, max_data] and weights in [0, max_w].
MrfProblem RandomProblem(std::mt19937& rng, int w, int h, int labels,
                         int max_data, int max_w, bool potts, int trunc) {
  MrfProblem pr;
  pr.width = w;
  pr.height = h;
  pr.num_labels = labels;
  pr.potts = potts;
  pr.truncation = trunc;
  const int n = w * h;
  std::uniform_int_distribution<int> data(0, max_data), weight(0, max_w);
  pr.data.resize(static_cast<size_t>(n * labels));
  for (uint16_t& d : pr.data) d = static_cast<uint16_t>(data(rng));
  pr.right.assign(static_cast<size_t>(n), 0);
  pr.down.assign(static_cast<size_t>(n), 0);
  for (int p = 0; p < n; ++p) {
    if (p % w + 1 < w) pr.right[static_cast<size_t>(p)] = weight(rng);
    if (p + w < n) pr.down[static_cast<size_t>(p)] = weight(rng);
  }
  return pr;
}

int64_t BruteForceMinimum(const MrfProblem& pr) {
  const int n = pr.width * pr.height;
  std::vector<int32_t> labels(static_cast<size_t>(n), 0);
  int64_t best = std::numeric_limits<int64_t>::max();
  while (true) {
    best = std::min(best, Energy(pr, labels));
    int i = 0;
    while (i < n && ++labels[static_cast<size_t>(i)] == pr.num_labels) {
      labels[static_cast<size_t>(i)] = 0;
      ++i;
    }
    if (i == n) break;
  }
  return best;
}

// Potts: alpha-expansion is guaranteed within 2x of the optimum (BVZ 2001,
// c = 1 for Potts). On 3x3 / 3-label instances (3^9 labellings enumerated)
// we assert that bound on every instance and exactness on >= 95 % of them.
TEST(AlphaExpansionTest, PottsMatchesBruteForceOnTinyProblems) {
  std::mt19937 rng(7);
  int exact = 0;
  constexpr int kInstances = 300;
  for (int t = 0; t < kInstances; ++t) {
    const MrfProblem pr = RandomProblem(rng, 3, 3, 3, 20, 12, true, 1);
    std::vector<int32_t> labels = WinnerTakesAll(pr);
    absl::StatusOr<SolverStats> stats = AlphaExpansion(pr, &labels);
    ASSERT_TRUE(stats.ok()) << stats.status();
    const int64_t optimum = BruteForceMinimum(pr);
    EXPECT_EQ(stats->energy_after, Energy(pr, labels));
    EXPECT_LE(stats->energy_after, stats->energy_before);
    EXPECT_GE(stats->energy_after, optimum);
    EXPECT_LE(stats->energy_after, 2 * optimum) << "instance " << t;
    if (stats->energy_after == optimum) ++exact;
  }
  // Measured: 294 of 300 exact (seed 7).
  EXPECT_GE(exact, kInstances * 95 / 100) << exact << " of " << kInstances;
}

// Leaving dominated pixels out of the graphs is exact: same result as the
// full graphs, from the data minimum and from random labellings (where
// pixels start, or after a switch end up, far above their minimum cost: a
// pixel list made from the minimum alone misses some of their moves; such a
// list gave other labellings on 20 of these 200 instances).
TEST(AlphaExpansionTest, PruningDoesNotChangeTheResult) {
  std::mt19937 rng(9);
  for (int t = 0; t < 200; ++t) {
    const MrfProblem pr = RandomProblem(rng, 10, 8, 6, 100 + 50 * (t % 5),
                                        30 + 10 * (t % 7), true, 1);
    std::vector<int32_t> start = WinnerTakesAll(pr);
    if (t % 2 == 1) {
      std::uniform_int_distribution<int> any(0, pr.num_labels - 1);
      for (int32_t& l : start) l = any(rng);
    }
    std::vector<int32_t> pruned = start;
    std::vector<int32_t> full = start;
    absl::StatusOr<SolverStats> a = AlphaExpansion(pr, &pruned, 20, true);
    absl::StatusOr<SolverStats> b = AlphaExpansion(pr, &full, 20, false);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(a->energy_after, b->energy_after) << "instance " << t;
    // Potts moves are exact cuts and max-flow returns the smallest set of
    // switching pixels among the optimal moves, which the pruning keeps.
    EXPECT_EQ(pruned, full) << "instance " << t;
    EXPECT_LE(a->graph_nodes, b->graph_nodes);
  }
}

// The sparse data term of `dense`, built the plain way (every label below
// the pixel's largest cost).
MrfProblem Sparse(const MrfProblem& dense) {
  MrfProblem pr = dense;
  const int n = pr.width * pr.height;
  pr.far.assign(static_cast<size_t>(n), 0);
  pr.near_begin.assign(1, 0);
  for (int p = 0; p < n; ++p) {
    uint16_t far = 0;
    for (int l = 0; l < pr.num_labels; ++l) {
      far = std::max(far, pr.data[static_cast<size_t>(l * n + p)]);
    }
    pr.far[static_cast<size_t>(p)] = far;
    for (int l = 0; l < pr.num_labels; ++l) {
      const uint16_t c = pr.data[static_cast<size_t>(l * n + p)];
      if (c < far) pr.near.push_back({static_cast<uint16_t>(l), c});
    }
    pr.near_begin.push_back(static_cast<int64_t>(pr.near.size()));
  }
  pr.data.clear();
  return pr;
}

// Dense, sparse, or both: the same energies and labellings, with and without
// pruning and with allowed labels. Data costs often at the maximum, as in
// fusion, so the sparse views are really sparse.
TEST(AlphaExpansionTest, SparseDataTermGivesTheSameResult) {
  std::mt19937 rng(13);
  std::uniform_int_distribution<int> coin(0, 3);
  for (int t = 0; t < 40; ++t) {
    MrfProblem dense = RandomProblem(rng, 9, 7, 7, 120, 30, t % 4 != 3, 6);
    for (uint16_t& d : dense.data) {
      if (coin(rng) != 0) d = 120;
    }
    if (t % 3 == 0) {
      dense.allowed.resize(dense.data.size());
      for (uint8_t& a : dense.allowed) a = coin(rng) != 0 ? 1 : 0;
    }
    MrfProblem sparse = Sparse(dense);
    MrfProblem both = sparse;
    both.data = dense.data;
    const std::vector<int32_t> start = WinnerTakesAll(dense);
    EXPECT_EQ(WinnerTakesAll(sparse), start) << "instance " << t;
    for (bool prune : {true, false}) {
      std::vector<int32_t> a = start, b = start, c = start;
      absl::StatusOr<SolverStats> sa = AlphaExpansion(dense, &a, 20, prune);
      absl::StatusOr<SolverStats> sb = AlphaExpansion(sparse, &b, 20, prune);
      absl::StatusOr<SolverStats> sc = AlphaExpansion(both, &c, 20, prune);
      ASSERT_TRUE(sa.ok() && sb.ok() && sc.ok()) << sb.status();
      EXPECT_EQ(a, b) << "instance " << t;
      EXPECT_EQ(a, c) << "instance " << t;
      EXPECT_EQ(sa->energy_after, sb->energy_after);
      EXPECT_EQ(sb->energy_after, Energy(sparse, b));
      EXPECT_EQ(Energy(dense, a), Energy(sparse, a));
    }
  }
}

TEST(AlphaExpansionTest, RejectsMalformedSparseDataTerm) {
  std::mt19937 rng(2);
  MrfProblem dense = RandomProblem(rng, 3, 3, 4, 30, 5, true, 1);
  dense.data[5] = 31;  // the maximum of pixel 5; its other labels are near
  const MrfProblem sparse = Sparse(dense);
  std::vector<int32_t> labels(9, 0);
  ASSERT_TRUE(AlphaExpansion(sparse, &labels).ok());
  MrfProblem bad = sparse;
  bad.near[0].label = 4;  // out of range
  EXPECT_THAT(AlphaExpansion(bad, &labels),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("fusion: malformed sparse data view")));
  bad = sparse;
  bad.near[0].cost = bad.far[0];  // not below the constant
  EXPECT_THAT(AlphaExpansion(bad, &labels),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("fusion: malformed sparse data view")));
  bad = sparse;
  std::swap(bad.near[bad.near_begin[5]], bad.near[bad.near_begin[5] + 1]);
  // not by label
  EXPECT_THAT(AlphaExpansion(bad, &labels),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("fusion: malformed sparse data view")));
  bad = sparse;
  bad.near_begin.pop_back();
  EXPECT_THAT(AlphaExpansion(bad, &labels),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("fusion: malformed sparse data view")));
  bad = sparse;
  bad.data.resize(3);  // neither empty nor complete
  EXPECT_THAT(AlphaExpansion(bad, &labels),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("fusion: the data term needs num_labels costs "
                                 "per pixel, or the sparse view")));
}

// With two labels and every pixel at label 0, one expansion on label 1
// spans every labelling: the result is the global optimum.
TEST(AlphaExpansionTest, TwoLabelsIsExact) {
  std::mt19937 rng(11);
  for (int t = 0; t < 100; ++t) {
    const MrfProblem pr = RandomProblem(rng, 4, 3, 2, 30, 20, true, 1);
    std::vector<int32_t> labels(12, 0);
    absl::StatusOr<SolverStats> stats = AlphaExpansion(pr, &labels);
    ASSERT_TRUE(stats.ok());
    EXPECT_EQ(stats->energy_after, BruteForceMinimum(pr)) << "instance " << t;
  }
}

// Truncated quadratic smoothness is not a metric (non-submodular moves are
// truncated); the acceptance test still keeps the energy from increasing
// and the bookkeeping exact.
TEST(AlphaExpansionTest, QuadraticNeverIncreasesEnergy) {
  std::mt19937 rng(3);
  for (int t = 0; t < 30; ++t) {
    const MrfProblem pr = RandomProblem(rng, 3, 3, 4, 40, 6, false, 9);
    std::vector<int32_t> labels(9);
    std::uniform_int_distribution<int> any(0, 3);
    for (int32_t& l : labels) l = any(rng);
    const int64_t before = Energy(pr, labels);
    absl::StatusOr<SolverStats> stats = AlphaExpansion(pr, &labels);
    ASSERT_TRUE(stats.ok());
    EXPECT_EQ(stats->energy_before, before);
    EXPECT_LE(stats->energy_after, before);
    EXPECT_EQ(stats->energy_after, Energy(pr, labels));
    EXPECT_GE(stats->energy_after, BruteForceMinimum(pr));
  }
}

TEST(AlphaExpansionTest, LargerRandomProblemNeverIncreases) {
  std::mt19937 rng(5);
  const MrfProblem pr = RandomProblem(rng, 40, 30, 16, 200, 60, true, 1);
  std::vector<int32_t> labels(1200);
  std::uniform_int_distribution<int> any(0, 15);
  for (int32_t& l : labels) l = any(rng);
  absl::StatusOr<SolverStats> stats = AlphaExpansion(pr, &labels);
  ASSERT_TRUE(stats.ok());
  EXPECT_LT(stats->energy_after, stats->energy_before);
  EXPECT_EQ(stats->energy_after, Energy(pr, labels));
  // Converged: a further run accepts nothing.
  absl::StatusOr<SolverStats> again = AlphaExpansion(pr, &labels);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->accepted, 0);
  EXPECT_EQ(again->energy_after, stats->energy_after);
}

TEST(AlphaExpansionTest, RejectsBadInput) {
  std::mt19937 rng(1);
  const MrfProblem pr = RandomProblem(rng, 3, 3, 3, 5, 5, true, 1);
  std::vector<int32_t> short_labels(4, 0);
  EXPECT_THAT(
      AlphaExpansion(pr, &short_labels),
      StatusIs(
          absl::StatusCode::kInvalidArgument,
          HasSubstr("fusion: the labelling must have one label per pixel")));
  std::vector<int32_t> bad(9, 3);
  EXPECT_THAT(AlphaExpansion(pr, &bad),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("fusion: initial label 3 out of [0, 3)")));
  EXPECT_THAT(
      AlphaExpansion(pr, nullptr),
      StatusIs(
          absl::StatusCode::kInvalidArgument,
          HasSubstr("fusion: the labelling must have one label per pixel")));
  MrfProblem broken = pr;
  broken.data.pop_back();
  std::vector<int32_t> ok(9, 0);
  EXPECT_THAT(AlphaExpansion(broken, &ok),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("fusion: the data term needs num_labels costs "
                                 "per pixel, or the sparse view")));
  MrfProblem heavy = pr;
  heavy.right[0] = 1 << 30;
  EXPECT_THAT(
      AlphaExpansion(heavy, &ok),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("fusion: smoothness weight x rho cap exceeds 2^26")));
  heavy = pr;
  heavy.down[0] = -1;
  EXPECT_THAT(AlphaExpansion(heavy, &ok),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("fusion: negative smoothness weight")));
}

// A piecewise-constant disparity map (three vertical bands) and a guide with
// intensity edges at the band borders.
constexpr int kW = 48, kH = 32, kMaxDisp = 40;

cv::Mat Truth() {
  cv::Mat d(kH, kW, CV_32FC1);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      d.at<float>(y, x) = x < 16 ? 8.0f : (x < 32 ? 20.0f : 33.0f);
    }
  }
  return d;
}

cv::Mat Guide() {
  cv::Mat g(kH, kW, CV_8UC3);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      const uchar v = x < 16 ? 40 : (x < 32 ? 140 : 230);
      g.at<cv::Vec3b>(y, x) = cv::Vec3b(v, v, v);
    }
  }
  return g;
}

FusionOptions Params() {
  FusionOptions p;
  p.max_disp = kMaxDisp;
  return p;
}

TEST(FuseTest, IdenticalCandidatesGiveTheCandidate) {
  const cv::Mat truth = Truth();
  const std::vector<cv::Mat> cands(7, truth);
  for (SmoothnessModel s :
       {SmoothnessModel::kPottsLinear, SmoothnessModel::kPotts,
        SmoothnessModel::kPottsStaticCue, SmoothnessModel::kQuadratic}) {
    FusionOptions p = Params();
    p.smoothness = s;
    absl::StatusOr<FusionResult> r = FuseAlphaExpansion(cands, Guide(), p);
    ASSERT_TRUE(r.ok()) << r.status();
    EXPECT_EQ(cv::norm(r->disparity, truth, cv::NORM_INF), 0.0);
    EXPECT_EQ(r->stats.energy_after, r->stats.energy_before);
  }
}

TEST(FuseTest, OneCorruptedCandidateAmongSeven) {
  const cv::Mat truth = Truth();
  std::mt19937 rng(42);
  std::normal_distribution<float> noise(0.0f, 0.25f);
  std::uniform_real_distribution<float> garbage(0.0f, kMaxDisp);
  std::vector<cv::Mat> cands;
  for (int k = 0; k < 6; ++k) {
    cv::Mat c = truth.clone();
    for (float& v : cv::Mat_<float>(c)) v += noise(rng);
    cands.push_back(c);
  }
  cv::Mat bad(kH, kW, CV_32FC1);
  for (float& v : cv::Mat_<float>(bad)) v = garbage(rng);
  cands.insert(cands.begin() + 3, bad);
  for (bool fusion_move : {false, true}) {
    FusionOptions p = Params();
    p.candidate_labels_only = fusion_move;
    absl::StatusOr<FusionResult> r = FuseAlphaExpansion(cands, Guide(), p);
    ASSERT_TRUE(r.ok()) << r.status();
    EXPECT_LE(cv::norm(r->disparity, truth, cv::NORM_INF), 1.0)
        << "fusion_move=" << fusion_move;
  }
  // The mean baseline is pulled off by the corrupted candidate.
  absl::StatusOr<cv::Mat> mean = FuseMean(cands, kMaxDisp);
  ASSERT_TRUE(mean.ok());
  EXPECT_GT(cv::norm(*mean, truth, cv::NORM_INF), 1.0);
}

// The fusion MRF of candidates with wrong regions, where most pixels are
// dominated for most labels: pruning, the neighbour-aware Potts bound and
// skipped expansions leave the labelling unchanged and the graphs smaller.
TEST(FuseTest, PruningKeepsTheLabellingOfACandidateProblem) {
  const cv::Mat truth = Truth();
  std::mt19937 rng(5);
  std::normal_distribution<float> noise(0.0f, 0.4f);
  std::uniform_real_distribution<float> any(0.0f, kMaxDisp);
  std::uniform_int_distribution<int> px(0, kW - 1), py(0, kH - 1);
  std::vector<cv::Mat> cands;
  for (int k = 0; k < 5; ++k) {
    cv::Mat c = truth.clone();
    for (float& v : cv::Mat_<float>(c)) v += noise(rng);
    for (int b = 0; b < 4; ++b) {
      cv::circle(c, cv::Point(px(rng), py(rng)), 5, cv::Scalar(any(rng)),
                 cv::FILLED);
    }
    cands.push_back(c);
  }
  for (SmoothnessModel s :
       {SmoothnessModel::kPottsLinear, SmoothnessModel::kQuadratic}) {
    FusionOptions p = Params();
    p.smoothness = s;
    absl::StatusOr<MrfProblem> pr = BuildProblem(cands, Guide(), p);
    ASSERT_TRUE(pr.ok()) << pr.status();
    std::vector<int32_t> pruned = WinnerTakesAll(*pr);
    std::vector<int32_t> full = pruned;
    absl::StatusOr<SolverStats> a = AlphaExpansion(*pr, &pruned, 20, true);
    absl::StatusOr<SolverStats> b = AlphaExpansion(*pr, &full, 20, false);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_LT(a->energy_after, a->energy_before);
    EXPECT_EQ(a->energy_after, b->energy_after);
    EXPECT_EQ(a->energy_after, Energy(*pr, pruned));
    EXPECT_LE(a->graph_nodes, b->graph_nodes);
    if (s == SmoothnessModel::kPottsLinear) {
      EXPECT_EQ(pruned, full);
      EXPECT_LT(a->graph_nodes, b->graph_nodes / 4)
          << a->graph_nodes << " vs " << b->graph_nodes;
    }
  }
}

// Appendix A useEdge: pairs whose right / lower pixel is a guide edge lose
// their smoothness weight; elsewhere the weights are unchanged.
TEST(FuseTest, EdgeWeightCutsPairsAtGuideEdges) {
  cv::Mat guide(kH, kW, CV_8UC1, cv::Scalar(40));
  guide.colRange(24, kW).setTo(cv::Scalar(200));
  const std::vector<cv::Mat> cands(3, Truth());
  FusionOptions p = Params();
  absl::StatusOr<MrfProblem> plain = BuildProblem(cands, guide, p);
  p.edge_weight = 0;
  absl::StatusOr<MrfProblem> cut = BuildProblem(cands, guide, p);
  ASSERT_TRUE(plain.ok() && cut.ok());
  for (int y = 0; y + 1 < kH; ++y) {
    const size_t row = static_cast<size_t>(y * kW);
    // The step lies between x = 23 and 24; the thinned edge is x = 24.
    EXPECT_EQ(plain->right[row + 23], 1);  // max(40 - 160, 1)
    EXPECT_EQ(cut->right[row + 23], 0);
    EXPECT_EQ(plain->down[row + 24], 40);
    EXPECT_EQ(cut->down[row + 24], 0);
    for (int x : {10, 23, 25, 40}) {
      EXPECT_EQ(cut->down[row + static_cast<size_t>(x)], 40) << x;
      EXPECT_EQ(cut->right[row + static_cast<size_t>(x) + 1],
                plain->right[row + static_cast<size_t>(x) + 1]);
    }
  }
  p.edge_weight = 1.5;
  EXPECT_THAT(
      BuildProblem(cands, guide, p),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("fusion: edge_weight is 1.5; it must be in [0, 1]")));
}

TEST(FuseTest, InvalidCandidatesContributeNothing) {
  const cv::Mat truth = Truth();
  std::vector<cv::Mat> cands(5, truth);
  // Two candidates are wrong everywhere but marked invalid.
  cands.push_back(cv::Mat(kH, kW, CV_32FC1,
                          cv::Scalar(std::numeric_limits<float>::quiet_NaN())));
  cands.push_back(cv::Mat(kH, kW, CV_32FC1, cv::Scalar(-1.0f)));
  // A hole where no candidate is valid: filled from the neighbours.
  for (int k = 0; k < 5; ++k) {
    cands[static_cast<size_t>(k)] = truth.clone();
    cands[static_cast<size_t>(k)](cv::Rect(4, 10, 4, 4)) =
        std::numeric_limits<float>::quiet_NaN();
  }
  absl::StatusOr<FusionResult> r = FuseAlphaExpansion(cands, Guide(), Params());
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(cv::norm(r->disparity, truth, cv::NORM_INF), 0.0);
  absl::StatusOr<cv::Mat> median = FuseMedian(cands, kMaxDisp);
  ASSERT_TRUE(median.ok());
  EXPECT_TRUE(std::isnan(median->at<float>(11, 5)));
  EXPECT_EQ(median->at<float>(0, 0), 8.0f);
}

TEST(FuseTest, ConfidenceWeightsDecide) {
  const cv::Mat truth = Truth();
  const cv::Mat wrong = truth + 5.0f;
  const std::vector<cv::Mat> cands = {truth, wrong, wrong};
  const cv::Mat high(kH, kW, CV_32FC1, cv::Scalar(1.0f));
  const cv::Mat low(kH, kW, CV_32FC1, cv::Scalar(0.2f));
  absl::StatusOr<FusionResult> r =
      FuseAlphaExpansion(cands, Guide(), Params(), {high, low, low});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(cv::norm(r->disparity, truth, cv::NORM_INF), 0.0);
  r = FuseAlphaExpansion(cands, Guide(), Params());
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(cv::norm(r->disparity, wrong, cv::NORM_INF), 0.0);
}

TEST(FuseTest, MeanAndMedian) {
  std::vector<cv::Mat> cands = {cv::Mat(1, 2, CV_32FC1, cv::Scalar(1.0f)),
                                cv::Mat(1, 2, CV_32FC1, cv::Scalar(2.0f)),
                                cv::Mat(1, 2, CV_32FC1, cv::Scalar(9.0f))};
  cands[2].at<float>(0, 1) = 100.0f;  // > max_disp: invalid
  absl::StatusOr<cv::Mat> mean = FuseMean(cands, 10);
  absl::StatusOr<cv::Mat> median = FuseMedian(cands, 10);
  ASSERT_TRUE(mean.ok() && median.ok());
  EXPECT_FLOAT_EQ(mean->at<float>(0, 0), 4.0f);
  EXPECT_FLOAT_EQ(mean->at<float>(0, 1), 1.5f);
  EXPECT_FLOAT_EQ(median->at<float>(0, 0), 2.0f);
  EXPECT_FLOAT_EQ(median->at<float>(0, 1), 1.5f);
}

TEST(FuseTest, RejectsBadInput) {
  const cv::Mat truth = Truth();
  const FusionOptions p = Params();
  EXPECT_EQ(FuseAlphaExpansion({}, Guide(), p).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_FALSE(
      FuseAlphaExpansion({truth, truth(cv::Rect(0, 0, 8, 8))}, Guide(), p)
          .ok());
  cv::Mat as_int;
  truth.convertTo(as_int, CV_32S);
  EXPECT_THAT(
      FuseAlphaExpansion({as_int}, Guide(), p),
      StatusIs(
          absl::StatusCode::kInvalidArgument,
          HasSubstr("fusion: candidate 0 must be a non-empty CV_32FC1 map")));
  EXPECT_THAT(FuseAlphaExpansion({truth}, cv::Mat(), p),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("fusion: the guide must be 48x32, got 0x0")));
  EXPECT_THAT(FuseAlphaExpansion({truth}, cv::Mat(kH, kW, CV_16UC1), p),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("fusion: the guide must be 8-bit or float [0, "
                                 "1], 1 or 3 channels")));
  EXPECT_THAT(
      FuseAlphaExpansion({truth}, Guide(), p, {truth, truth}),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("fusion: 2 confidence maps for 1 candidates")));
  FusionOptions bad = p;
  bad.sigma = 0;
  EXPECT_THAT(FuseAlphaExpansion({truth}, Guide(), bad),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("fusion: sigma is 0; it must be > 0")));
  bad = p;
  bad.max_disp = 0;
  EXPECT_THAT(
      FuseAlphaExpansion({truth}, Guide(), bad),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("fusion: max_disp must be in [1, 4096], got 0")));
  bad = p;
  bad.lambda = 1e9;
  EXPECT_THAT(
      FuseAlphaExpansion({truth}, Guide(), bad),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("fusion: lambda is 1e+09; it must be in [0, 1e4]")));
  bad = p;
  bad.data_scale = 60000;
  EXPECT_THAT(FuseAlphaExpansion({truth, truth}, Guide(), bad),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("data_scale too large")));
  EXPECT_THAT(FuseMean({}, 10),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("fusion: no candidate disparity maps")));
}

}  // namespace
}  // namespace hdrstereo::fusion

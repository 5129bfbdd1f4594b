// SPDX-License-Identifier: GPL-3.0-or-later
//
// Automatic exposure bracketing (the thesis chose its eight exposures by
// trial and error, ch. 3 "lessons learned"): a still scene is
// metered with a few linear probe frames per view, its radiance range is
// estimated, and the fewest exposures are chosen from the camera's shutter
// speeds such that every channel of every pixel of every view (emitters
// optionally excluded) has at least one well-exposed sample.
//
// The model, all in the camera's linear signal:
//  * Signal. x = fraction of the sensor's full scale; a pixel channel of
//    radiance r (full scales per second: 1/r is the exposure that just
//    saturates it) reads x = r * t at exposure t. Probes are linear (16-bit
//    TIFF or RAW decoded by LibRaw), so r = x / t needs no camera response:
//    the linear assumption holds by construction, and an 8-bit response is
//    never needed for metering.
//  * Noise. Shot plus read noise, sigma^2(x) = x / F + (R / F)^2 in units of
//    full scale, with F the full well and R the read noise in electrons,
//    both measured from two probes taken at the same exposure (photon
//    transfer: the variance of their difference against the signal).
//  * Well exposed. SNR(x) = x / sigma(x) >= min_snr, and x + 5 sigma(x) at
//    most the merge's saturation level (MergeOptions::linear_saturation):
//    the window [min_signal, max_signal].
//  * Estimates. Each channel's radiance comes from the probe with its
//    highest reading below saturation; a reading counts only inside the
//    window, so every estimate has SNR >= min_snr. The planner covers the
//    estimate +-5 of its standard deviations, so that the true radiance is
//    covered too (5 sigma: one miss in 3.5 million readings).
//  * Choice. Greedy interval stabbing from the brightest channel down
//    (optimal for equal-width windows): each exposure is the longest choice
//    that keeps the brightest channel not yet covered inside the window,
//    and neighbouring exposures are at most max_step_stops apart.
#ifndef HDRSTEREO_PROCESSING_HDR_AUTO_BRACKET_H_
#define HDRSTEREO_PROCESSING_HDR_AUTO_BRACKET_H_

#include <cstdint>
#include <functional>
#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace hdrstereo::hdr {

struct AutoBracketOptions {
  // Per sample. 40 is ISO 12232's "excellent" noise-based criterion (10 is
  // its "acceptable").
  double min_snr = 40;
  // Neighbouring exposures at most this far apart (stops). The pipeline
  // recovers an 8-bit camera response from the bracket itself (Debevec &
  // Malik), which needs overlapping exposures: on the simulated scenes a
  // 2-stop spacing made the recovered response add 2-5x the merge error of
  // a 1-stop spacing, as the thesis' own 1-stop bracket avoids.
  // This default is for linear frames (16-bit TIFF, RAW); 8-bit frames
  // take kMaxStepStops8Bit.
  double max_step_stops = 1;
  // 0: emitters are kept (and must be covered like every pixel). > 1: a
  // pixel whose brightest channel exceeds this multiple of its view's
  // median is an emitter (a lamp): excluded from coverage and reported.
  double exclude_emitters_above = 0;
  // A bracket leaving more of the non-emitter pixels uncovered than this
  // fraction is refused (AcceptCoverage); 0: every pixel must be covered.
  double max_uncovered_fraction = 0;
  // No exposure longer than this (s); 0: the camera's longest.
  double max_exposure_s = 0;

  // INVALID_ARGUMENT naming the first field that breaks a rule.
  absl::Status Validate() const;
};
// Canonical JSON (processing/base/options.h).
void to_json(nlohmann::json& j, const AutoBracketOptions& o);

// The step between neighbours for 8-bit frames (JPEG, 8-bit PNG), whose
// merge averages quantised samples: on the bundled simulated scenes, 1-stop
// brackets merged 8-bit frames worse than the thesis' eight on the three
// low-range ones (their 3 or 4 frames give a pixel few samples, and the
// response is recovered from few exposures), 2/3 stop merged every scene
// better (AutoBracketScenesTest, docs/results.md). Chosen on the simulated
// scenes only: no real bracket with exact radiance was at hand.
inline constexpr double kMaxStepStops8Bit = 2.0 / 3;

// The pipeline merges at least two exposures.
inline constexpr int kMinBracketExposures = 2;

// Shot + read noise of a linear sensor, in units of its full scale.
struct SensorNoise {
  double full_well_e = 0;   // F
  double read_noise_e = 0;  // R
  int levels = 0;           // signal levels the measurement used

  double Sigma(double x) const;
  double Snr(double x) const;
};

// Photon transfer from two linear frames of the same still scene at the
// same exposure (CV_32F, 1 or 3 channels, full scale 1): the variance of
// their difference against the signal, in bins of signal, fitted with
// sigma^2 = x / F + (R / F)^2 by weighted least squares. A fit that finds
// a negative intercept sets R to 0. INVALID_ARGUMENT for frames that do not
// match; FAILED_PRECONDITION when fewer than two signal levels hold enough
// pixels (a featureless or black scene) or the slope is not positive.
absl::StatusOr<SensorNoise> MeasureSensorNoise(const cv::Mat& a,
                                               const cv::Mat& b,
                                               double saturation);

// The well-exposed signal range, fractions of full scale.
struct ExposureWindow {
  double min_signal = 0;  // SNR(min_signal) == min_snr
  double max_signal = 0;  // max_signal + 5 sigma == saturation
  double min_snr = 0;
  double Stops() const;  // log2(max / min)
};
// FAILED_PRECONDITION when the sensor cannot reach `min_snr` below
// saturation (the message gives the best SNR it reaches).
absl::StatusOr<ExposureWindow> WellExposedWindow(const SensorNoise& noise,
                                                 double min_snr,
                                                 double saturation);

// A DSLR's nominal third-stop shutter speeds (1/8000 .. 30 s) within
// [min_s, max_s], ascending: the choices of a camera that takes any
// exposure in a range (the simulator) rather than a list (gphoto2's
// `shutterspeed` choices).
std::vector<double> ThirdStopShutterSpeeds(double min_s, double max_s);

// One probe frame of a view: linear signal (CV_32FC3 or CV_32FC1, full scale
// 1) at `exposure_s`.
struct Probe {
  cv::Mat signal;
  double exposure_s = 0;
};

// The exposure of the next probe of a view, from the choices (ascending);
// nullopt when every channel has a reading in [min_signal, saturation), or
// no choice can improve on the probes taken. Without probes: the choice
// nearest the middle of the choices (in stops). A probe reaches at most
// max_signal / (min_signal (1 + 5 / min_snr)) times further than the last,
// so that a channel just outside the window of one probe reads inside it,
// 5 sigma clear, in the next. A channel clipped in every probe asks for a
// shorter one (as short as that allows); one below the window in every
// probe asks for the exposure that lifts the darkest such channel to twice
// min_signal, at least one stop longer; one below the window in a probe
// and clipped in the next longer asks for a probe between them.
std::optional<double> NextProbeExposure(const std::vector<Probe>& probes,
                                        const ExposureWindow& window,
                                        double saturation,
                                        const std::vector<double>& choices);

// A view's estimated radiance, per channel.
enum class ChannelState : uint8_t {
  kMeasured = 0,
  kTooBright = 1,  // at or above saturation even in the shortest probe
  kTooDark = 2,    // below the window even in the longest probe
};
struct RadianceEstimate {
  cv::Mat radiance;   // CV_32FC(n): full scales per second (r = x / t)
  cv::Mat rel_sigma;  // CV_32FC(n): sigma / x of the reading used
  cv::Mat state;      // CV_8UC(n): ChannelState
};
// INVALID_ARGUMENT without probes or with probes that do not match.
absl::StatusOr<RadianceEstimate> EstimateRadiance(
    const std::vector<Probe>& probes, const SensorNoise& noise,
    const ExposureWindow& window, double saturation);

struct AutoBracketResult {
  std::vector<double> exposures_s;  // chosen, longest first
  SensorNoise noise;
  ExposureWindow window;
  double min_snr = 0;
  // The non-emitter channels measured (full scales per second): darkest and
  // brightest; 0 when none was measured.
  double radiance_min = 0;
  double radiance_max = 0;
  // What the camera's choices can cover: window.min_signal / longest and
  // window.max_signal / shortest allowed choice.
  double camera_radiance_min = 0;
  double camera_radiance_max = 0;
  double emitter_ratio = 0;    // options.exclude_emitters_above
  int64_t pixels = 0;          // of all views
  int64_t emitter_pixels = 0;  // excluded (exclude_emitters_above)
  // Non-emitter pixels with a channel the bracket does not cover, and of
  // those: with a channel too bright (no choice short enough) and with one
  // too dark (no allowed choice long enough, or no choice inside its
  // window); a pixel may be both.
  int64_t uncovered_pixels = 0;
  int64_t uncovered_bright = 0;
  int64_t uncovered_dark = 0;
  int probes = 0;  // probe frames taken, all views (MeterAndChoose)

  double SceneStops() const;   // log2(radiance_max / radiance_min)
  double CameraStops() const;  // log2 of the camera's radiance range
  double EmitterFraction() const;
  double UncoveredFraction() const;  // of the non-emitter pixels
  double Coverage() const { return 1 - UncoveredFraction(); }
  // "12.3 stops (1/1600 .. 2 s at SNR >= 40), 100.00 % covered, 491
  // emitter pixels (0.27 %) excluded": the reason, for people.
  std::string Reason() const;
  // Rows for a report's summary table.
  std::vector<std::pair<std::string, std::string>> SummaryRows() const;
};
// The canonical JSON of a result (stored with the capture) and back.
void to_json(nlohmann::json& j, const AutoBracketResult& r);
absl::StatusOr<AutoBracketResult> AutoBracketFromJson(const std::string& text);

// Chooses the bracket for the views' estimates (all of the same channel
// count) from `choices` (ascending, seconds; those above
// options.max_exposure_s are not used). Channels the probes could not
// measure, and channels no choice covers, are counted as uncovered; the
// result is the best coverage the choices allow. INVALID_ARGUMENT for bad
// options, no choices or no views.
absl::StatusOr<AutoBracketResult> ChooseBracket(
    const std::vector<RadianceEstimate>& views, const ExposureWindow& window,
    const SensorNoise& noise, const std::vector<double>& choices,
    const AutoBracketOptions& options);

// Takes one linear probe frame (CV_32F, full scale 1) of view `view` at
// `exposure_s`, one of the choices.
using ProbeTaker =
    std::function<absl::StatusOr<cv::Mat>(int view, double exposure_s)>;

// Meters `views` views through `take` and chooses their bracket: view 0's
// first probe (the choice nearest the middle of the camera's range, in
// stops) is taken twice to measure the sensor's noise, then each view is
// probed until NextProbeExposure is done (at most one probe per choice),
// its radiance estimated, and ChooseBracket decides. `choices` ascending,
// already limited to options.max_exposure_s. Errors of `take` are
// returned as they are.
absl::StatusOr<AutoBracketResult> MeterAndChoose(
    int views, const ProbeTaker& take, const std::vector<double>& choices,
    double saturation, const AutoBracketOptions& options);

// OK when the result leaves at most options.max_uncovered_fraction of the
// non-emitter pixels uncovered; else FAILED_PRECONDITION giving the scene's
// range, the camera's, the uncovered fraction and what to do.
absl::Status AcceptCoverage(const AutoBracketResult& result,
                            const AutoBracketOptions& options);

}  // namespace hdrstereo::hdr

#endif  // HDRSTEREO_PROCESSING_HDR_AUTO_BRACKET_H_

// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/hdr/auto_bracket.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::hdr {
namespace {

using nlohmann::json;

// The estimate of a channel is covered with this many of its standard
// deviations on either side: a normal reading strays further once in 3.5
// million, fewer than the channels of a 1200 x 900 stereo pair.
constexpr double kEstimateSigmas = 5;
// A sample must keep this many standard deviations of its noise below
// saturation, for the same reason.
constexpr double kHeadroomSigmas = 5;

// Photon transfer: signal bins of a quarter stop from 2^-12 of full scale
// (below it even a 16-bit reading is mostly read noise and quantisation);
// a bin needs this many channel readings for its variance to be known to
// +-15 % (relative standard error sqrt(2 / n)).
constexpr double kBinsPerStop = 4;
constexpr double kLowestBinSignal = 1.0 / 4096;
constexpr int kMinBinReadings = 100;
// Signal levels the photon-transfer fit needs, at least a stop apart at
// their ends, to tell the shot-noise slope from the read-noise floor.
constexpr int kMinNoiseLevels = 2;

// An exposure for people: "1/1338 s", "0.5 s", "120 s".
std::string ForPeople(double seconds) {
  if (seconds > 0 && seconds < 0.4) {
    return absl::StrFormat("1/%.0f s", 1 / seconds);
  }
  return absl::StrFormat("%.3g s", seconds);
}

absl::Status CheckProbe(const Probe& probe, const Probe& first, size_t i) {
  if (probe.signal.empty() || probe.signal.depth() != CV_32F ||
      (probe.signal.channels() != 1 && probe.signal.channels() != 3)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "probe ", i, " is not a linear CV_32F image of 1 or 3 channels"));
  }
  if (probe.signal.size() != first.signal.size() ||
      probe.signal.channels() != first.signal.channels()) {
    return absl::InvalidArgumentError(
        absl::StrCat("probe ", i, " differs in size or channels from probe 0"));
  }
  if (!(probe.exposure_s > 0) || !std::isfinite(probe.exposure_s)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "probe ", i, " has exposure ", probe.exposure_s, " s; it must be > 0"));
  }
  return absl::OkStatus();
}

// The value of every channel of `m` (continuous copy).
std::vector<float> Values(const cv::Mat& m) {
  cv::Mat c = m.isContinuous() ? m : m.clone();
  const float* p = c.ptr<float>();
  return std::vector<float>(p, p + c.total() * c.channels());
}

}  // namespace

double SensorNoise::Sigma(double x) const {
  return std::sqrt(std::max(x, 0.0) / full_well_e +
                   read_noise_e * read_noise_e / (full_well_e * full_well_e));
}

double SensorNoise::Snr(double x) const { return x / Sigma(x); }

absl::StatusOr<SensorNoise> MeasureSensorNoise(const cv::Mat& a,
                                               const cv::Mat& b,
                                               double saturation) {
  const Probe pa{a, 1}, pb{b, 1};
  RETURN_IF_ERROR(CheckProbe(pa, pa, 0));
  RETURN_IF_ERROR(CheckProbe(pb, pa, 1));
  const int bins = static_cast<int>(
      std::ceil(kBinsPerStop * std::log2(saturation / kLowestBinSignal)));
  std::vector<double> count(bins, 0), sum_x(bins, 0), sum_d2(bins, 0);
  const std::vector<float> va = Values(a), vb = Values(b);
  for (size_t i = 0; i < va.size(); ++i) {
    if (va[i] >= saturation || vb[i] >= saturation) continue;
    const double mean = 0.5 * (va[i] + vb[i]);
    if (mean < kLowestBinSignal) continue;
    const int bin = std::min(
        bins - 1,
        static_cast<int>(kBinsPerStop * std::log2(mean / kLowestBinSignal)));
    const double d = static_cast<double>(va[i]) - vb[i];
    count[bin] += 1;
    sum_x[bin] += mean;
    sum_d2[bin] += d * d;
  }
  // Weighted least squares of variance = slope * x + intercept; a bin's
  // weight is the inverse variance of its variance estimate, n / v^2.
  double sw = 0, swx = 0, swy = 0, swxx = 0, swxy = 0;
  double lowest = 0, highest = 0;
  int levels = 0;
  for (int k = 0; k < bins; ++k) {
    if (count[k] < kMinBinReadings) continue;
    const double x = sum_x[k] / count[k];
    const double v = sum_d2[k] / (2 * count[k]);  // var(a - b) = 2 sigma^2
    // Readings near saturation lose their upper tail to the clip: such a
    // bin's variance is biased low.
    if (v <= 0 || x + 4 * std::sqrt(v) > saturation) continue;
    const double w = count[k] / (v * v);
    sw += w;
    swx += w * x;
    swy += w * v;
    swxx += w * x * x;
    swxy += w * x * v;
    lowest = levels == 0 ? x : lowest;
    highest = x;
    ++levels;
  }
  if (levels < kMinNoiseLevels || highest < 2 * lowest) {
    return absl::FailedPreconditionError(absl::StrFormat(
        "the probes show %d signal level(s) over %.1f stops; measuring the "
        "sensor's noise needs %d levels at least a stop apart (is the scene "
        "featureless or black?)",
        levels, levels > 0 ? std::log2(highest / lowest) : 0.0,
        kMinNoiseLevels));
  }
  const double det = sw * swxx - swx * swx;
  const double slope = (sw * swxy - swx * swy) / det;
  const double intercept = (swy - slope * swx) / sw;
  if (!(slope > 0) || !std::isfinite(slope)) {
    return absl::FailedPreconditionError(absl::StrFormat(
        "the probes' noise does not grow with the signal (slope %g): they "
        "are not linear frames of a still scene",
        slope));
  }
  SensorNoise noise;
  noise.full_well_e = 1 / slope;
  noise.read_noise_e = std::sqrt(std::max(intercept, 0.0)) / slope;
  noise.levels = levels;
  return noise;
}

double ExposureWindow::Stops() const {
  return std::log2(max_signal / min_signal);
}

absl::StatusOr<ExposureWindow> WellExposedWindow(const SensorNoise& noise,
                                                 double min_snr,
                                                 double saturation) {
  const double f = noise.full_well_e, r = noise.read_noise_e;
  ExposureWindow w;
  // x / sigma(x) = s  <=>  x^2 = s^2 (x / F + R^2 / F^2).
  w.min_signal = min_snr * min_snr / (2 * f) *
                 (1 + std::sqrt(1 + 4 * r * r / (min_snr * min_snr)));
  // x + k sigma(x) = saturation: with u = sigma, u^2 + (k / F) u -
  // (saturation / F + R^2 / F^2) = 0.
  const double k = kHeadroomSigmas;
  const double u =
      0.5 * (-k / f + std::sqrt(k * k / (f * f) +
                                4 * (saturation / f + r * r / (f * f))));
  w.max_signal = saturation - k * u;
  w.min_snr = min_snr;
  if (!(w.min_signal < w.max_signal)) {
    return absl::FailedPreconditionError(absl::StrFormat(
        "the sensor (full well %.0f e-, read noise %.1f e-) reaches SNR %.1f "
        "at most below saturation; min_snr %g is out of its reach",
        f, r, noise.Snr(std::max(w.max_signal, 0.0)), min_snr));
  }
  return w;
}

std::vector<double> ThirdStopShutterSpeeds(double min_s, double max_s) {
  static constexpr double kDenominators[] = {
      8000, 6400, 5000, 4000, 3200, 2500, 2000, 1600, 1250, 1000, 800, 640,
      500,  400,  320,  250,  200,  160,  125,  100,  80,   60,   50,  40,
      30,   25,   20,   15,   13,   10,   8,    6,    5,    4};
  static constexpr double kSeconds[] = {0.3, 0.4, 0.5, 0.6, 0.8, 1,  1.3,
                                        1.6, 2,   2.5, 3.2, 4,   5,  6,
                                        8,   10,  13,  15,  20,  25, 30};
  std::vector<double> all;
  for (double d : kDenominators) all.push_back(1 / d);
  for (double s : kSeconds) all.push_back(s);
  std::vector<double> out;
  for (double t : all) {
    if (t >= min_s * (1 - 1e-9) && t <= max_s * (1 + 1e-9)) out.push_back(t);
  }
  return out;
}

std::optional<double> NextProbeExposure(const std::vector<Probe>& probes,
                                        const ExposureWindow& window,
                                        double saturation,
                                        const std::vector<double>& choices) {
  if (choices.empty()) return std::nullopt;
  if (probes.empty()) {
    // The geometric middle of the camera's range: the fewest probes to
    // either end.
    const double middle = std::sqrt(choices.front() * choices.back());
    return *std::min_element(choices.begin(), choices.end(),
                             [middle](double x, double y) {
                               return std::abs(std::log(x / middle)) <
                                      std::abs(std::log(y / middle));
                             });
  }
  std::vector<const Probe*> sorted;
  for (const Probe& p : probes) sorted.push_back(&p);
  std::sort(sorted.begin(), sorted.end(), [](const Probe* a, const Probe* b) {
    return a->exposure_s < b->exposure_s;
  });
  const double shortest = sorted.front()->exposure_s;
  const double longest = sorted.back()->exposure_s;
  // Every channel without a reading in [min_signal, saturation): clipped in
  // every probe that reads it above the window (too bright), below it in
  // every one (too dark), or below in one and clipped in the next longer
  // (between two probes).
  std::vector<std::vector<float>> values;
  for (const Probe* p : sorted) values.push_back(Values(p->signal));
  bool bright = false, dark = false;
  double darkest = std::numeric_limits<double>::infinity();
  std::optional<std::pair<double, double>> between;
  for (size_t i = 0; i < values[0].size(); ++i) {
    double below = 0, clipped = 0;  // exposures; 0 = none
    bool measured = false;
    for (size_t k = 0; k < values.size() && !measured; ++k) {
      const double x = values[k][i];
      if (x >= saturation) {
        if (clipped == 0) clipped = sorted[k]->exposure_s;
      } else if (x >= window.min_signal) {
        measured = true;
      } else {
        below = sorted[k]->exposure_s;
      }
    }
    if (measured) continue;
    if (clipped == 0) {
      dark = true;
      darkest = std::min(darkest, static_cast<double>(values.back()[i]));
    } else if (below == 0) {
      bright = true;
    } else if (below < clipped && !between.has_value()) {
      between = {below, clipped};
    }
  }
  // A channel just outside the window of one probe lands in it, its
  // reading kEstimateSigmas clear of the window's ends, at most `reach`
  // times longer or shorter.
  const double reach =
      window.max_signal /
      (window.min_signal * (1 + kEstimateSigmas / window.min_snr));
  if (bright) {
    // The shortest choice at most `reach` shorter, if any is shorter.
    const double bound = shortest / reach * (1 - 1e-9);
    for (double t : choices) {
      if (t >= bound && t < shortest * (1 - 1e-9)) return t;
    }
  }
  if (dark) {
    const double bound = longest * reach;
    // Twice min_signal for the darkest, at least a stop further.
    const double want =
        darkest > 0 ? std::clamp(longest * 2 * window.min_signal / darkest,
                                 std::min(2 * longest, bound), bound)
                    : bound;
    std::optional<double> best;
    for (double t : choices) {
      if (t <= longest * (1 + 1e-9) || t > bound * (1 + 1e-9)) continue;
      // The shortest choice at or above `want`, else the longest below it.
      if (!best.has_value() || (*best < want && t > *best) ||
          (t >= want && t < *best)) {
        best = t;
      }
    }
    if (best.has_value()) return best;
  }
  if (between.has_value()) {
    // The choice nearest their geometric middle, strictly between them.
    const double middle = std::sqrt(between->first * between->second);
    std::optional<double> best;
    for (double t : choices) {
      if (t <= between->first * (1 + 1e-9) ||
          t >= between->second * (1 - 1e-9)) {
        continue;
      }
      if (!best.has_value() ||
          std::abs(std::log(t / middle)) < std::abs(std::log(*best / middle))) {
        best = t;
      }
    }
    return best;
  }
  return std::nullopt;
}

absl::StatusOr<RadianceEstimate> EstimateRadiance(
    const std::vector<Probe>& probes, const SensorNoise& noise,
    const ExposureWindow& window, double saturation) {
  if (probes.empty()) return absl::InvalidArgumentError("no probes");
  for (size_t i = 0; i < probes.size(); ++i) {
    RETURN_IF_ERROR(CheckProbe(probes[i], probes[0], i));
  }
  const int channels = probes[0].signal.channels();
  const cv::Size size = probes[0].signal.size();
  RadianceEstimate out;
  out.radiance.create(size, CV_32FC(channels));
  out.rel_sigma.create(size, CV_32FC(channels));
  out.state.create(size, CV_8UC(channels));
  double shortest = probes[0].exposure_s, longest = shortest;
  for (const Probe& p : probes) {
    shortest = std::min(shortest, p.exposure_s);
    longest = std::max(longest, p.exposure_s);
  }
  const int n = size.width * channels;
  for (int y = 0; y < size.height; ++y) {
    float* r = out.radiance.ptr<float>(y);
    float* s = out.rel_sigma.ptr<float>(y);
    uint8_t* state = out.state.ptr<uint8_t>(y);
    for (int i = 0; i < n; ++i) {
      // The highest reading with its noise clear of the clip, else the
      // highest below the clip (its SNR is the best there is).
      double best_x = -1, best_t = 0, clear_x = -1, clear_t = 0;
      for (const Probe& p : probes) {
        const double x = p.signal.ptr<float>(y)[i];
        if (x >= saturation) continue;
        if (x > best_x) {
          best_x = x;
          best_t = p.exposure_s;
        }
        if (x <= window.max_signal && x > clear_x) {
          clear_x = x;
          clear_t = p.exposure_s;
        }
      }
      if (clear_x >= window.min_signal) {
        best_x = clear_x;
        best_t = clear_t;
      }
      if (best_x < 0) {  // clipped in every probe: a lower bound
        r[i] = static_cast<float>(saturation / shortest);
        s[i] = 0;
        state[i] = static_cast<uint8_t>(ChannelState::kTooBright);
      } else if (best_x < window.min_signal) {  // an upper bound
        r[i] = static_cast<float>(best_x / best_t);
        s[i] = 0;
        state[i] = static_cast<uint8_t>(ChannelState::kTooDark);
      } else {
        r[i] = static_cast<float>(best_x / best_t);
        s[i] = static_cast<float>(noise.Sigma(best_x) / best_x);
        state[i] = static_cast<uint8_t>(ChannelState::kMeasured);
      }
    }
  }
  return out;
}

double AutoBracketResult::SceneStops() const {
  return radiance_min > 0 ? std::log2(radiance_max / radiance_min) : 0;
}

double AutoBracketResult::CameraStops() const {
  return camera_radiance_min > 0
             ? std::log2(camera_radiance_max / camera_radiance_min)
             : 0;
}

double AutoBracketResult::EmitterFraction() const {
  return pixels > 0 ? static_cast<double>(emitter_pixels) / pixels : 0;
}

double AutoBracketResult::UncoveredFraction() const {
  const int64_t scored = pixels - emitter_pixels;
  return scored > 0 ? static_cast<double>(uncovered_pixels) / scored : 0;
}

std::string AutoBracketResult::Reason() const {
  std::vector<std::string> list;
  for (double t : exposures_s) list.push_back(ForPeople(t));
  return absl::StrFormat(
      "%d exposures (%s) for a scene of %.1f stops: every sample at SNR >= "
      "%g below %.2f of full scale; %.2f %% of the non-emitter pixels "
      "covered; %s",
      exposures_s.size(), absl::StrJoin(list, ", "), SceneStops(), min_snr,
      window.max_signal, 100 * Coverage(),
      emitter_pixels > 0
          ? absl::StrFormat("%d emitter pixels (%.2f %%) excluded",
                            emitter_pixels, 100 * EmitterFraction())
          : std::string("no emitters excluded"));
}

std::vector<std::pair<std::string, std::string>>
AutoBracketResult::SummaryRows() const {
  std::vector<std::string> list;
  for (double t : exposures_s) list.push_back(ForPeople(t));
  const auto at = [](double radiance, double signal) {
    return radiance > 0 ? ForPeople(signal / radiance) : std::string("-");
  };
  return {
      {"auto bracket", absl::StrFormat("%d exposures: %s", exposures_s.size(),
                                       absl::StrJoin(list, ", "))},
      {"scene range",
       absl::StrFormat("%.1f stops: the brightest channel saturates at %s, "
                       "the darkest reaches SNR %g at %s",
                       SceneStops(), at(radiance_max, window.max_signal),
                       min_snr, at(radiance_min, window.min_signal))},
      {"coverage",
       absl::StrFormat("%.2f %% of the non-emitter pixels (%d uncovered: %d "
                       "too bright, %d too dark)",
                       100 * Coverage(), uncovered_pixels, uncovered_bright,
                       uncovered_dark)},
      {"emitters excluded",
       emitter_ratio > 0
           ? absl::StrFormat("%d pixels (%.2f %%) brighter than %g x their "
                             "view's median",
                             emitter_pixels, 100 * EmitterFraction(),
                             emitter_ratio)
           : std::string("none (not asked for)")},
      {"noise model",
       absl::StrFormat("shot + read noise measured on the probes: full well "
                       "%.0f e-, read noise %.1f e-; well exposed = %.4f .. "
                       "%.3f of full scale",
                       noise.full_well_e, noise.read_noise_e, window.min_signal,
                       window.max_signal)},
  };
}

void to_json(json& j, const AutoBracketResult& r) {
  j = json{{"exposures_s", r.exposures_s},
           {"full_well_e", r.noise.full_well_e},
           {"read_noise_e", r.noise.read_noise_e},
           {"noise_levels", r.noise.levels},
           {"min_signal", r.window.min_signal},
           {"max_signal", r.window.max_signal},
           {"min_snr", r.min_snr},
           {"radiance_min", r.radiance_min},
           {"radiance_max", r.radiance_max},
           {"camera_radiance_min", r.camera_radiance_min},
           {"camera_radiance_max", r.camera_radiance_max},
           {"emitter_ratio", r.emitter_ratio},
           {"pixels", r.pixels},
           {"emitter_pixels", r.emitter_pixels},
           {"uncovered_pixels", r.uncovered_pixels},
           {"uncovered_bright", r.uncovered_bright},
           {"uncovered_dark", r.uncovered_dark},
           {"probes", r.probes}};
}

absl::StatusOr<AutoBracketResult> AutoBracketFromJson(const std::string& text) {
  AutoBracketResult r;
  try {
    const json j = json::parse(text);
    j.at("exposures_s").get_to(r.exposures_s);
    j.at("full_well_e").get_to(r.noise.full_well_e);
    j.at("read_noise_e").get_to(r.noise.read_noise_e);
    j.at("noise_levels").get_to(r.noise.levels);
    j.at("min_signal").get_to(r.window.min_signal);
    j.at("max_signal").get_to(r.window.max_signal);
    j.at("min_snr").get_to(r.min_snr);
    j.at("radiance_min").get_to(r.radiance_min);
    j.at("radiance_max").get_to(r.radiance_max);
    j.at("camera_radiance_min").get_to(r.camera_radiance_min);
    j.at("camera_radiance_max").get_to(r.camera_radiance_max);
    j.at("emitter_ratio").get_to(r.emitter_ratio);
    j.at("pixels").get_to(r.pixels);
    j.at("emitter_pixels").get_to(r.emitter_pixels);
    j.at("uncovered_pixels").get_to(r.uncovered_pixels);
    j.at("uncovered_bright").get_to(r.uncovered_bright);
    j.at("uncovered_dark").get_to(r.uncovered_dark);
    j.at("probes").get_to(r.probes);
  } catch (const json::exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("not an automatic bracket record: ", e.what()));
  }
  for (double t : r.exposures_s) {
    if (!(t > 0) || !std::isfinite(t)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "automatic bracket record: exposure ", t, " s is not > 0"));
    }
  }
  return r;
}

absl::StatusOr<AutoBracketResult> ChooseBracket(
    const std::vector<RadianceEstimate>& views, const ExposureWindow& window,
    const SensorNoise& noise, const std::vector<double>& choices,
    const AutoBracketOptions& options) {
  RETURN_IF_ERROR(options.Validate());
  if (views.empty()) return absl::InvalidArgumentError("no views to bracket");
  std::vector<double> allowed;
  for (double t : choices) {
    if (options.max_exposure_s == 0 ||
        t <= options.max_exposure_s * (1 + 1e-9)) {
      allowed.push_back(t);
    }
  }
  std::sort(allowed.begin(), allowed.end());
  if (allowed.empty()) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "max_exposure_s is %g s, shorter than every exposure the camera "
        "offers (%s at the shortest)",
        options.max_exposure_s,
        choices.empty() ? "none" : ForPeople(choices.front())));
  }
  AutoBracketResult result;
  result.noise = noise;
  result.window = window;
  result.min_snr = options.min_snr;
  result.emitter_ratio = options.exclude_emitters_above;
  result.camera_radiance_min = window.min_signal / allowed.back();
  result.camera_radiance_max = window.max_signal / allowed.front();

  // Per channel to cover: the exposures that put its estimate, give or
  // take kEstimateSigmas, into the window.
  struct Need {
    float lo_t,
        hi_t;  // [min_signal / (r (1 - k s)), max_signal / (r (1 + k s))]
    int64_t pixel;
  };
  std::vector<Need> needs;
  std::vector<uint8_t> uncovered;  // per pixel: 1 too bright, 2 too dark
  double r_min = std::numeric_limits<double>::infinity(), r_max = 0;
  for (const RadianceEstimate& view : views) {
    if (view.radiance.channels() != views[0].radiance.channels()) {
      return absl::InvalidArgumentError("views differ in their channels");
    }
    const int channels = view.radiance.channels();
    const std::vector<float> r = Values(view.radiance);
    const std::vector<float> s = Values(view.rel_sigma);
    cv::Mat state_mat =
        view.state.isContinuous() ? view.state : view.state.clone();
    const uint8_t* state = state_mat.ptr<uint8_t>();
    const int64_t pixels = static_cast<int64_t>(view.radiance.total());
    double threshold = std::numeric_limits<double>::infinity();
    if (options.exclude_emitters_above > 0) {
      std::vector<float> brightest(pixels);
      for (int64_t p = 0; p < pixels; ++p) {
        brightest[p] =
            *std::max_element(&r[p * channels], &r[p * channels] + channels);
      }
      std::nth_element(brightest.begin(), brightest.begin() + pixels / 2,
                       brightest.end());
      threshold = options.exclude_emitters_above * brightest[pixels / 2];
    }
    for (int64_t p = 0; p < pixels; ++p) {
      const int64_t pixel = result.pixels + p;
      uncovered.push_back(0);
      const float* rp = &r[p * channels];
      if (*std::max_element(rp, rp + channels) > threshold) {
        ++result.emitter_pixels;
        continue;
      }
      for (int c = 0; c < channels; ++c) {
        const int64_t i = p * channels + c;
        const auto st = static_cast<ChannelState>(state[i]);
        if (st == ChannelState::kTooBright) {
          uncovered[pixel] |= 1;
          continue;
        }
        if (st == ChannelState::kTooDark) {
          uncovered[pixel] |= 2;
          continue;
        }
        r_min = std::min(r_min, static_cast<double>(r[i]));
        r_max = std::max(r_max, static_cast<double>(r[i]));
        needs.push_back(
            {static_cast<float>(window.min_signal /
                                (r[i] * (1 - kEstimateSigmas * s[i]))),
             static_cast<float>(window.max_signal /
                                (r[i] * (1 + kEstimateSigmas * s[i]))),
             pixel});
      }
    }
    result.pixels += pixels;
  }
  if (r_max > 0) {
    result.radiance_min = r_min;
    result.radiance_max = r_max;
  }

  // Greedy interval stabbing, brightest first: each exposure the longest
  // choice that still covers the brightest channel not yet covered (or
  // the longest within max_step_stops of the last one).
  std::sort(needs.begin(), needs.end(),
            [](const Need& a, const Need& b) { return a.hi_t < b.hi_t; });
  const double step = std::exp2(options.max_step_stops);
  std::vector<double> chosen;  // ascending
  for (const Need& need : needs) {
    if (!chosen.empty() && need.lo_t <= chosen.back() * (1 + 1e-6)) continue;
    auto longest_at_most = [&](double bound) -> std::optional<double> {
      std::optional<double> best;
      for (double t : allowed) {
        if (t <= bound * (1 + 1e-6)) best = t;
      }
      return best;
    };
    const std::optional<double> t = longest_at_most(need.hi_t);
    if (!t.has_value()) {  // even the shortest choice saturates it
      uncovered[need.pixel] |= 1;
      continue;
    }
    if (*t < need.lo_t * (1 - 1e-6)) {  // no choice inside its window
      uncovered[need.pixel] |= 2;
      continue;
    }
    // Each next exposure the longest that covers the need, at most
    // max_step_stops after the last (for the response recovery): until one
    // covers it, those are bridges.
    while (chosen.empty() || chosen.back() < need.lo_t * (1 - 1e-6)) {
      if (chosen.empty()) {
        chosen.push_back(*t);
        break;
      }
      std::optional<double> next =
          longest_at_most(std::min(*t, chosen.back() * step));
      if (!next.has_value() || *next <= chosen.back() * (1 + 1e-6)) {
        // The camera has nothing in between: its next longer choice.
        next = *std::upper_bound(allowed.begin(), allowed.end(),
                                 chosen.back() * (1 + 1e-6));
      }
      chosen.push_back(*next);
    }
  }
  // The merge needs two: one more step longer (more signal for the darkest),
  // else shorter.
  if (chosen.size() == 1) {
    const double t = chosen[0];
    std::optional<double> extra;
    for (double c : allowed) {
      if (c > t * (1 + 1e-6) && c <= t * step * (1 + 1e-6)) extra = c;
    }
    for (auto it = allowed.rbegin(); !extra.has_value() && it != allowed.rend();
         ++it) {
      if (*it < t * (1 - 1e-6) && *it >= t / step * (1 - 1e-6)) extra = *it;
    }
    if (extra.has_value()) chosen.push_back(*extra);
  }
  std::sort(chosen.begin(), chosen.end(), std::greater<double>());
  result.exposures_s = chosen;
  for (uint8_t u : uncovered) {
    result.uncovered_pixels += u != 0;
    result.uncovered_bright += (u & 1) != 0;
    result.uncovered_dark += (u & 2) != 0;
  }
  return result;
}

absl::StatusOr<AutoBracketResult> MeterAndChoose(
    int views, const ProbeTaker& take, const std::vector<double>& choices,
    double saturation, const AutoBracketOptions& options) {
  RETURN_IF_ERROR(options.Validate());
  if (views < 1) return absl::InvalidArgumentError("no views to meter");
  if (choices.empty()) {
    return absl::InvalidArgumentError("the camera offers no exposures");
  }
  std::vector<std::vector<Probe>> probes(views);
  std::optional<SensorNoise> noise;
  std::optional<ExposureWindow> window;
  int taken = 0;
  for (int v = 0; v < views; ++v) {
    // Each probe extends the shortest or the longest exposure of the view,
    // so there are at most as many as choices.
    for (size_t i = 0; i <= choices.size(); ++i) {
      std::optional<double> t =
          window.has_value()
              ? NextProbeExposure(probes[v], *window, saturation, choices)
              : NextProbeExposure({}, {}, saturation, choices);
      if (!t.has_value()) break;
      ASSIGN_OR_RETURN(cv::Mat signal, take(v, *t));
      ++taken;
      probes[v].push_back({std::move(signal), *t});
      if (!noise.has_value()) {
        ASSIGN_OR_RETURN(cv::Mat again, take(v, *t));
        ++taken;
        ASSIGN_OR_RETURN(
            noise, MeasureSensorNoise(probes[v][0].signal, again, saturation));
        ASSIGN_OR_RETURN(
            window, WellExposedWindow(*noise, options.min_snr, saturation));
      }
    }
  }
  std::vector<RadianceEstimate> estimates;
  for (const std::vector<Probe>& view : probes) {
    ASSIGN_OR_RETURN(RadianceEstimate e,
                     EstimateRadiance(view, *noise, *window, saturation));
    estimates.push_back(std::move(e));
  }
  ASSIGN_OR_RETURN(AutoBracketResult result,
                   ChooseBracket(estimates, *window, *noise, choices, options));
  result.probes = taken;
  return result;
}

absl::Status AcceptCoverage(const AutoBracketResult& result,
                            const AutoBracketOptions& options) {
  const int64_t scored = result.pixels - result.emitter_pixels;
  if (result.UncoveredFraction() <= options.max_uncovered_fraction &&
      static_cast<int>(result.exposures_s.size()) >= kMinBracketExposures) {
    return absl::OkStatus();
  }
  if (static_cast<int>(result.exposures_s.size()) < kMinBracketExposures &&
      result.uncovered_pixels < scored) {
    return absl::FailedPreconditionError(absl::StrFormat(
        "the camera offers no two exposures within %g stops of each other "
        "around %s",
        options.max_step_stops,
        result.exposures_s.empty() ? std::string("-")
                                   : ForPeople(result.exposures_s[0])));
  }
  const auto at = [](double radiance, double signal) {
    return radiance > 0 ? ForPeople(signal / radiance) : std::string("-");
  };
  // What the probes saw of the scene: nothing at all when every channel was
  // too bright or too dark in every probe (then the scene's range is not
  // known, only that it lies outside the camera's).
  const std::string scene =
      result.radiance_max > 0
          ? absl::StrFormat(
                "the scene spans at least %.1f stops (where measured its "
                "brightest channel saturates at %s, its darkest reaches SNR "
                "%g at %s)",
                result.SceneStops(),
                at(result.radiance_max, result.window.max_signal),
                result.min_snr,
                at(result.radiance_min, result.window.min_signal))
          : std::string(
                "no channel of the scene could be measured (every one was "
                "too bright or too dark in every probe),");
  // Only the remedies that apply.
  std::vector<std::string> remedies;
  if (result.uncovered_bright > 0 && result.emitter_ratio <= 0) {
    remedies.push_back(
        "exclude the emitters (exclude_emitters_above, e.g. 100: lamps are "
        "then reported, not covered)");
  }
  if (result.uncovered_dark > 0 && options.max_exposure_s > 0) {
    remedies.push_back("allow longer exposures (max_exposure_s)");
  }
  remedies.push_back("accept the uncovered fraction (max_uncovered_fraction)");
  std::string advice = remedies.back();
  if (remedies.size() > 1) {
    remedies.pop_back();
    advice = absl::StrCat(absl::StrJoin(remedies, ", "), " or ", advice);
  }
  advice[0] = static_cast<char>(std::toupper(advice[0]));
  return absl::FailedPreconditionError(absl::StrFormat(
      "the scene's range exceeds what the camera offers: %s and the camera "
      "covers %.1f stops (%s .. %s, samples at SNR >= %g below %.2f of full "
      "scale); %.2f %% of the non-emitter pixels (%d of %d) stay uncovered, "
      "at most %.2f %% may: %d too bright even at %s, %d too dark even at "
      "%s. %s",
      scene, result.CameraStops(),
      at(result.camera_radiance_max, result.window.max_signal),
      at(result.camera_radiance_min, result.window.min_signal), result.min_snr,
      result.window.max_signal, 100 * result.UncoveredFraction(),
      result.uncovered_pixels, scored, 100 * options.max_uncovered_fraction,
      result.uncovered_bright,
      at(result.camera_radiance_max, result.window.max_signal),
      result.uncovered_dark,
      at(result.camera_radiance_min, result.window.min_signal), advice));
}

}  // namespace hdrstereo::hdr

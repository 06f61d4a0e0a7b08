// tacmap-working-resolution: how many map pixels per taxel the localizer should match at
// (localizer_config::working_mm_per_px), measured on photographs through the front door.
//
// Each photograph becomes an object whose longer side is --object-mm (180 mm: a 640 x 480
// photograph at 0.28 mm per px), photographed at a fine scale (--fine-px-per-taxel, 6: 0.57 mm
// per px). The simulator presses a 4 mm relief made from it (height = intensity) at that fine
// scale; `tacmap::localizer` is built from the fine photograph with working_mm_per_px = pitch / k
// for each k of --k (k equal to the fine one: matching at full resolution). Every k sees the same
// sequences: --sequences per photograph, 7 touches each at random positions a random walk apart
// (odometry noise 0.5 mm per axis). Printed per k: sequences within 5 mm at the last touch, the
// median last error, the build's time and a touch's median time.
//
//   tacmap-working-resolution photo.png [photo.png ...] [--k 2,3,4,6] [--sequences 6]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "tacmap/image.hpp"
#include "tacmap/io/image_file.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/sim/random.hpp"
#include "tacmap/sim/tactile_simulator.hpp"

namespace {

struct tally {
  int within_5mm = 0;
  int sequences = 0;
  std::vector<double> last_errors, touch_ms, build_ms;
};

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

std::vector<double> parse_list(const std::string& text) {
  std::vector<double> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) out.push_back(std::stod(item));
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  using clock = std::chrono::steady_clock;
  std::vector<std::string> photos;
  std::vector<double> ks = {2, 3, 4, 6};
  double fine_k = 6.0, object_mm = 180.0;
  int sequences = 6, touches = 7;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto next = [&] { return std::string(i + 1 < argc ? argv[++i] : ""); };
    if (a == "--k")
      ks = parse_list(next());
    else if (a == "--sequences")
      sequences = std::stoi(next());
    else if (a == "--fine-px-per-taxel")
      fine_k = std::stod(next());
    else if (a == "--object-mm")
      object_mm = std::stod(next());
    else
      photos.push_back(a);
  }
  if (photos.empty()) {
    std::fprintf(stderr,
                 "usage: tacmap-working-resolution photo... [--k 2,3,4,6] [--sequences N]\n");
    return 2;
  }
  const tacmap::taxel_geometry sensor{};
  const double fine = sensor.pitch_mm / fine_k;
  std::vector<tally> results(ks.size());
  for (const std::string& path : photos) {
    const tacmap::image<float> photo = tacmap::load_image(std::filesystem::path(path));
    const double longer = static_cast<double>(std::max(photo.rows(), photo.cols()));
    const double f = object_mm / fine / longer;
    const tacmap::image<float> map =
        tacmap::resize_area(photo, std::lround(static_cast<double>(photo.rows()) * f),
                            std::lround(static_cast<double>(photo.cols()) * f));
    const double width_mm = static_cast<double>(map.cols()) * fine;
    const double height_mm = static_cast<double>(map.rows()) * fine;
    const double half_w = 0.5 * static_cast<double>(sensor.cols) * sensor.pitch_mm;
    const double half_h = 0.5 * static_cast<double>(sensor.rows) * sensor.pitch_mm;
    for (std::size_t j = 0; j < ks.size(); ++j) {
      tacmap::localizer_config config;
      config.working_mm_per_px = sensor.pitch_mm / ks[j];
      if (ks[j] >= fine_k) config.working_mm_per_px = fine;  // full resolution
      const auto start = clock::now();
      tacmap::localizer loc(map, fine, config, sensor);
      results[j].build_ms.push_back(
          std::chrono::duration<double, std::milli>(clock::now() - start).count());
      tacmap::sim_rng rng(0x5eed + std::hash<std::string>{}(path));
      for (int s = 0; s < sequences; ++s) {
        tacmap::tactile_simulator sim(map * 4.0F, {.width = map.cols(), .height = map.rows()}, fine,
                                      {.seed = rng.next_u64()});
        loc.reset();
        const auto place = [&] {
          return tacmap::map_pose{.x_mm = half_w + rng.uniform() * (width_mm - 2 * half_w),
                                  .y_mm = half_h + rng.uniform() * (height_mm - 2 * half_h)};
        };
        tacmap::map_pose at = place();
        tacmap::touch_result r;
        for (int t = 0; t < touches; ++t) {
          tacmap::map_pose to = t == 0 ? at : place();
          // Short moves: within 20 mm of the previous touch where the map allows.
          if (t > 0) {
            to.x_mm = std::clamp(at.x_mm + (to.x_mm - at.x_mm) * 0.2, half_w, width_mm - half_w);
            to.y_mm = std::clamp(at.y_mm + (to.y_mm - at.y_mm) * 0.2, half_h, height_mm - half_h);
          }
          const tacmap::tactile_frame frame = sim.render(to);
          const auto t0 = clock::now();
          if (t == 0)
            r = loc.touch(frame);
          else
            r = loc.touch(frame, tacmap::odometry{.dx_mm = to.x_mm - at.x_mm + 0.5 * rng.normal(),
                                                  .dy_mm = to.y_mm - at.y_mm + 0.5 * rng.normal()});
          results[j].touch_ms.push_back(
              std::chrono::duration<double, std::milli>(clock::now() - t0).count());
          at = to;
        }
        const double error = std::hypot(r.position_mm.x() - at.x_mm, r.position_mm.y() - at.y_mm);
        results[j].last_errors.push_back(error);
        results[j].within_5mm += error <= 5.0 ? 1 : 0;
        ++results[j].sequences;
      }
    }
    std::fprintf(stderr, "%s done (%ld x %ld px at %.3g mm/px)\n", path.c_str(),
                 static_cast<long>(map.cols()), static_cast<long>(map.rows()), fine);
  }
  std::printf(
      "| px per taxel | mm per px | within 5 mm at touch %d | median last error | build | touch "
      "|\n",
      touches);
  std::printf("|---|---|---|---|---|---|\n");
  for (std::size_t j = 0; j < ks.size(); ++j) {
    const double k = std::min(ks[j], fine_k);
    std::printf("| %.3g%s | %.3g | %d of %d | %.2f mm | %.0f ms | %.2f ms |\n", k,
                k >= fine_k ? " (full)" : "", sensor.pitch_mm / k, results[j].within_5mm,
                results[j].sequences, median(results[j].last_errors), median(results[j].build_ms),
                median(results[j].touch_ms));
  }
  return 0;
}

#pragma once
// One age for an island (docs/SPEC.md "Age"): how long ago its shield was
// built sets both how far it has sunk (the subsidence λ: fringing reef →
// barrier reef → atoll, Darwin's sequence) and how far rivers have
// dissected it (the erosion maturity: a young shield's shallow radial
// gullies → an old island's deep valleys between high ridges). Either can
// be set on its own: `subsidence` (with age_myr unset) and `maturity`.
#include "reefgen/procgen/spec.hpp"

namespace reefgen::procgen {

// A spec field that is not set.
inline constexpr double kNotSet = -1;
inline constexpr double kMaxAgeMyr = 60;
inline constexpr double kMinMaturity = 0.05, kMaxMaturity = 20;

// Subsidence follows the square root of age, as the sea floor under a
// hotspot island cools and sinks (depth ∝ √t: Parsons & Sclater 1977;
// Detrick & Crough 1978 for hotspot swells): λ(t) = min(1, √(t / T)), T the
// age at which the island is an atoll. T = 25 My puts the Society Islands
// about where they are (approximate K–Ar ages of their shields): Moorea
// (~1.5–2 My) λ ≈ 0.27, a young barrier reef; Bora Bora (~3.5 My) 0.37, a
// barrier reef round a high island; Maupiti (~4.5 My) 0.42, a small high
// island in a wide lagoon. Hotspots differ in pace (the Hawaiian islands
// carry fringing reefs at 5 My): set `subsidence` to place an island off
// this curve.
inline constexpr double kAtollAgeMyr = 60;
double subsidence_of_age(double age_myr);

// Erosion maturity grows with time: the time eroded is the age, as a
// multiple of the generator's default erosion (erosion.duration_yr =
// 1.5e5 yr of the default K, a moderately dissected island) at
// kUnitMaturityAgeMyr. A young shield (0.25 My, Mauna Kea or Kohala
// on the island of Hawaiʻi) has maturity 0.25: shallow radial gullies,
// much of its land high; Kauaʻi (5 My) 5: valleys cut to the sea between
// ridges that stand. O'Hara et al. (Earth Surface Dynamics 12:709, 2024)
// find drainage density rising and basin hypsometry falling with edifice
// age over this range; `reefgen realism --dissection` measures both
// (docs/REALISM.md "Age and dissection").
inline constexpr double kUnitMaturityAgeMyr = 1;
double maturity_of_age(double age_myr);

// Channels begin at this contributing area once maturity is set (an aged
// spec): above it hillslopes only diffuse, so long erosion deepens valleys
// between ridges instead of lowering the whole flank to a plain
// (terrain::ErosionParams::channel_head_m2).
inline constexpr double kAgedChannelHeadM2 = 5e3;

// The spec with age_myr and maturity applied and both cleared: subsidence
// from the age (when set), erosion.duration_yr × maturity, more steps for
// the longer time, and a channel head. Unset fields: the spec unchanged
// (the same bytes as before ages existed).
IslandSpec aged(const IslandSpec& spec);

}  // namespace reefgen::procgen

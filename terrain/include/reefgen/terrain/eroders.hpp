#pragma once
// Eroders: each applies one equation to a height field for one time step, on
// the active cells of a routing (fastscapelib's eroders are the model). The
// surface is in metres; the sea and the canvas edge are the base level and
// do not move. Deterministic and single-threaded (docs/EROSION.md).
#include <vector>

#include <opencv2/core.hpp>

#include "reefgen/terrain/flow.hpp"

namespace reefgen::terrain {

// Detachment-limited stream power with n = 1 (Howard 1994), solved
// implicitly along the stack, receivers first (Braun & Willett 2013, eq. 19:
// O(n) and stable at any time step):
//   ∂h/∂t = −K A^m S   →   z_i ← (z_i + F z_r) / (1 + F),  F = K_i Δt A_i^m / L_i
// Where the receiver is higher (a closed depression routed to its spill
// point) the same update raises the cell towards it: sediment fills the
// basin instead of water standing in it. erodibility_k: K per cell,
// m^(1−2m)/yr; area_m2 from drainage.hpp.
// channel_head_m2 > 0: incision only where the drainage area reaches it
// (channels begin at a critical contributing area: Montgomery & Dietrich
// 1988); cells above a channel head are hillslope, shaped by diffusion
// alone, so the valleys cut back into steep heads between ridges that stay
// (the amphitheatre-headed valleys of old volcanic islands). 0: every cell
// incises (the drainage area of a cell is at least the cell's own).
void erode_stream_power(cv::Mat1f& height_m, const cv::Mat1f& erodibility_k, const FlowGraph& graph,
                        const std::vector<float>& area_m2, double dt_yr, double m_area,
                        double channel_head_m2 = 0);

// Linear hillslope diffusion ∂h/∂t = D ∇²h over Δt. On an infinite plane its
// solution is the Gaussian of σ = √(2 D Δt): exact for the linear term, no
// stability limit (an explicit scheme needs Δt ≤ Δx²/4D, thousands of steps at
// 4097²). σ in cells:
double hillslope_sigma_px(double diffusivity_m2_per_yr, double dt_yr, double metres_per_px);
// Cells the Gaussian of sigma_px reaches beyond the land: the margin of the
// region blurred around the active cells.
int hillslope_margin_px(double sigma_px);
// The blur of `roi` (which holds every active cell and its margin), written
// to the active cells only, never below sea level. Below σ = 0.15 cells the
// blur changes nothing worth a pass and is skipped.
void diffuse_hillslope(cv::Mat1f& height_m, const cv::Mat1b& role, const cv::Rect& roi, double sigma_px);

// Creep between channels: soil creep rounds the ground where no channel
// runs and leaves the channels to incision (Gilbert 1909; the hillslope-
// channel transition of Montgomery & Dietrich 1988 at a contributing area
// A_c). Each active cell draining less than channel_area_m2 moves towards
// the Gaussian mean (σ = sigma_px) of its neighbourhood by the share
// (1 − A/A_c)², a channel cell not at all: ridges and bumps round off,
// hollows between them fill, channel floors stay where the incision put
// them. Never below sea level.
void creep_between_channels(cv::Mat1f& height_m, const cv::Mat1b& role, const cv::Rect& roi,
                            const std::vector<float>& area_m2, float channel_area_m2, double sigma_px);

}  // namespace reefgen::terrain

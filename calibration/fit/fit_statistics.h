#pragma once
// What a finished fit says about its data: the fitted model, the residual statistics per module
// and camera (robust inliers, in their natural units), the transfer check, and the notes a user
// must read about modules that were not estimated. Internal to parallax_fit.

#include "calibration/fit/fit_problem.h"

namespace parallax::fit {

// Fills result's model, modules, cameras, residual statistics and noise levels from `state`,
// the correspondences read in `form`; flags a transfer the stripes disagree with.
void summarizeResiduals(const FitInputs& in, const FitState& state, const CorrespondenceForm& form,
                        const NoiseLevels& sigmas, FitResult* result);

// Notes for the modules no camera saw and the modules held at their start.
void noteModulesNotEstimated(const FitInputs& in, FitResult* result);

}  // namespace parallax::fit

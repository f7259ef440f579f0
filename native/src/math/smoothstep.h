// The cubic smoothstep on [0, 1]: 0 below, 1 above, 3x^2 - 2x^3 between (zero slope at both
// ends). The blends that must start and stop without a kink use it: binding weights beside a
// joint, the fitted regions' seams, the muscle bulge, the armpit's web.
#pragma once

#include <algorithm>

namespace sd {

inline double smoothstep01(double x) {
    x = std::clamp(x, 0.0, 1.0);
    return x * x * (3.0 - 2.0 * x);
}

}  // namespace sd

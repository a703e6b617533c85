// SPDX-License-Identifier: Apache-2.0
// phongscene_PhongSurface, the seed convention (Suffern, Ray Tracing from the Ground Up, ch. 15):
//   L = ka*cd*La + sum_j [kd*cd/pi + ks*cs*max(0, r_j.wo)^e] * Lj * (n.l_j),  r_j = -l_j + 2(n.l_j)n
// One colour channel of one light's contribution, for n.l > 0 and the point not in shadow.
#pragma once
#include <cmath>

inline double phong_light_term(double kd, double cd, double ks, double cs, double e,
                               double n_dot_l, double r_dot_wo, double light) {
    const double specular = r_dot_wo > 0.0 ? ks * cs * std::pow(r_dot_wo, e) : 0.0;
    return (kd * cd / M_PI + specular) * light * n_dot_l;
}

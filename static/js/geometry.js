// Small pure helpers for drawing: uncertainty ellipses and angles. No DOM here (tested in the browser
// through page.evaluate).

// The chi-square quantile for 2 degrees of freedom at 95 %: the ellipse holds 95 % of the mass.
export const CHI2_2DOF_95 = 5.991;

// Semi-axes and orientation of the confidence ellipse of a 2x2 covariance [[sxx, sxy], [sxy, syy]]:
// eigen-decomposition in closed form. Returns {a, b, angle}: a >= b (metres), angle of the major axis
// counter-clockwise from +x (radians).
export function covarianceEllipse(cov, chi2 = CHI2_2DOF_95) {
  const sxx = cov[0][0];
  const sxy = cov[0][1];
  const syy = cov[1][1];
  const mean = (sxx + syy) / 2;
  const diff = (sxx - syy) / 2;
  const radius = Math.hypot(diff, sxy);
  const l1 = Math.max(mean + radius, 0);
  const l2 = Math.max(mean - radius, 0);
  const angle = 0.5 * Math.atan2(2 * sxy, sxx - syy);
  return { a: Math.sqrt(chi2 * l1), b: Math.sqrt(chi2 * l2), angle };
}

export function wrapAngle(a) {
  return Math.atan2(Math.sin(a), Math.cos(a));
}

export function degrees(rad) {
  return (rad * 180) / Math.PI;
}

// The paper's trajectory-helper, client side (same rule as backend/engine/trajectory.py):
// backward finite differences; most severe class wins: jerk > acceleration > velocity.
export const OK = 0, VELOCITY = 1, ACCELERATION = 2, JERK = 3;
export const CLASS_COLOURS = ["#3fbf5f", "#ff9a2e", "#ff6fb5", "#e5383b"];
export const CLASS_NAMES = ["ok", "velocity", "acceleration", "jerk"];

export function classify(x: number[], rate: number, vmax: number, amax: number, jmax: number, slack = 1e-9): number[] {
  const n = x.length;
  const v = new Array(n).fill(0), a = new Array(n).fill(0), j = new Array(n).fill(0);
  for (let i = 1; i < n; i++) v[i] = (x[i] - x[i - 1]) * rate;
  for (let i = 2; i < n; i++) a[i] = (v[i] - v[i - 1]) * rate;
  for (let i = 3; i < n; i++) j[i] = (a[i] - a[i - 1]) * rate;
  const k = 1 + slack;
  return x.map((_, i) => {
    if (Math.abs(j[i]) > jmax * k) return JERK;
    if (Math.abs(a[i]) > amax * k) return ACCELERATION;
    if (Math.abs(v[i]) > vmax * k) return VELOCITY;
    return OK;
  });
}

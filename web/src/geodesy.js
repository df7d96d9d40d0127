// WGS84 geodetic coordinates of an earth-centred (ECEF) point. A georeferenced tileset's root
// transform maps its east-north-up world to ECEF (docs/file-formats.md); its translation is
// the ENU origin, so the viewer can say where the map is while the job runs, before
// report.json exists.

const A = 6378137.0;  // WGS84 semi-major axis (m)
const F = 1 / 298.257223563;
const E2 = F * (2 - F);  // first eccentricity squared

// {latitude, longitude (degrees), altitude (m above the ellipsoid)} of ECEF (x, y, z) metres.
// Fixed-point iteration on the latitude; converges to < 1e-12 rad in a few steps away from the
// poles.
export function geodeticFromEcef(x, y, z) {
  const p = Math.hypot(x, y);
  const longitude = Math.atan2(y, x);
  let latitude = Math.atan2(z, p * (1 - E2));
  let altitude = 0;
  for (let i = 0; i < 10; i += 1) {
    const s = Math.sin(latitude);
    const n = A / Math.sqrt(1 - E2 * s * s);
    altitude = p / Math.cos(latitude) - n;
    const next = Math.atan2(z, p * (1 - E2 * n / (n + altitude)));
    if (Math.abs(next - latitude) < 1e-14) {
      latitude = next;
      break;
    }
    latitude = next;
  }
  return { latitude: latitude * 180 / Math.PI, longitude: longitude * 180 / Math.PI, altitude };
}

// The colour map of the surface's fields: three.js's 'rainbow' look-up table (blue, cyan, green,
// yellow, red), as runSofa colours its fields. Values are in [0, 1] (clamped); 1 is the hot end.
import { Lut } from 'three/examples/jsm/math/Lut.js';

const lut = new Lut('rainbow', 512);
lut.setMin(0);
lut.setMax(1);

function at(v) {
  return lut.getColor(Number.isFinite(v) ? Math.min(1, Math.max(0, v)) : 0);
}

/// Linear RGB (three.js's working colour space, as vertex colours are), in out[0..2].
export function colormap(v, out) {
  const c = at(v);
  out[0] = c.r; out[1] = c.g; out[2] = c.b;
  return out;
}

/// The same colour for a 2D canvas (sRGB).
export function colormapCss(v) {
  return at(v).getStyle();
}

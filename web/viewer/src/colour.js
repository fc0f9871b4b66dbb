// Colour maps of the 3D view, matching the report's pictures (io/report.h: OpenCV's turbo).

// Turbo (Mikhailov, Google 2019), the polynomial approximation of its lookup table: t in [0, 1]
// to [r, g, b] in [0, 1].
export function turbo(t) {
  const x = Math.min(1, Math.max(0, t));
  const x2 = x * x, x3 = x2 * x, x4 = x3 * x, x5 = x4 * x;
  const r = 0.13572138 + 4.6153926 * x - 42.66032258 * x2 + 132.13108234 * x3 -
            152.94239396 * x4 + 59.28637943 * x5;
  const g = 0.09140261 + 2.19418839 * x + 4.84296658 * x2 - 14.18503333 * x3 +
            4.27729857 * x4 + 2.82956604 * x5;
  const b = 0.1066733 + 12.64194608 * x - 60.58204836 * x2 + 110.36276771 * x3 -
            89.90310912 * x4 + 27.34824973 * x5;
  return [Math.min(1, Math.max(0, r)), Math.min(1, Math.max(0, g)), Math.min(1, Math.max(0, b))];
}

// Distinct colours for categories (views): Tableau 10.
const kCategories = [
  '#4e79a7', '#f28e2b', '#e15759', '#76b7b2', '#59a14f',
  '#edc948', '#b07aa1', '#ff9da7', '#9c755f', '#bab0ac',
];
export function categoryColour(i) {
  const hex = kCategories[((i % kCategories.length) + kCategories.length) % kCategories.length];
  return [1, 3, 5].map((k) => parseInt(hex.slice(k, k + 2), 16) / 255);
}
export function categoryCss(i) {
  const [r, g, b] = categoryColour(i);
  return `rgb(${Math.round(r * 255)},${Math.round(g * 255)},${Math.round(b * 255)})`;
}

export const kNoValue = [0.59, 0.59, 0.59];  // grey, as the pictures draw a missing value

// A colour bar on a canvas: the turbo gradient from lo to hi, five ticks, `label` below.
export function drawColourBar(canvas, lo, hi, label) {
  const ctx = canvas.getContext('2d');
  const w = canvas.width, h = canvas.height, margin = 12, strip = 12;
  ctx.fillStyle = '#fff';
  ctx.fillRect(0, 0, w, h);
  for (let x = margin; x < w - margin; ++x) {
    const [r, g, b] = turbo((x - margin) / Math.max(1, w - 2 * margin - 1));
    ctx.fillStyle = `rgb(${Math.round(r * 255)},${Math.round(g * 255)},${Math.round(b * 255)})`;
    ctx.fillRect(x, 2, 1, strip);
  }
  ctx.fillStyle = '#000';
  ctx.font = '11px sans-serif';
  ctx.textAlign = 'center';
  for (let k = 0; k <= 4; ++k) {
    const x = margin + (k * (w - 2 * margin - 1)) / 4;
    ctx.fillRect(Math.round(x), 2 + strip, 1, 4);
    const v = lo + ((hi - lo) * k) / 4;
    ctx.fillText(formatTick(v), Math.min(w - 20, Math.max(20, x)), 2 + strip + 15);
  }
  ctx.fillText(label, w / 2, h - 4);
}

export function formatTick(v) {
  const a = Math.abs(v);
  if (a === 0) return '0';
  return a < 0.01 || a >= 1e5 ? v.toPrecision(2) : String(Number(v.toPrecision(4)));
}

// quantile.js: the p-quantile of a few numbers, as the page's figures (delays, intervals,
// offsets) are summarised.

/** The p-quantile (0..1) of numbers, by sorting a copy; undefined for none. */
export function quantile(values, p) {
  const sorted = [...values].sort((a, b) => a - b);
  return sorted[Math.min(sorted.length - 1, Math.floor(p * sorted.length))];
}

// chart.js: the live lip-roughness chart: the summary mean of every frame received (drawn
// or skipped), one line per view in the view's colour, over the last ten seconds, with the
// canvas 2D API.

const WINDOW_MS = 10_000;

/** At most this many steps up the value axis. */
const GRID_STEPS = 4;

/** The smallest of 1, 2, 2.5, 5 x 10^k that is at least `x`. */
function niceStep(x) {
  const power = 10 ** Math.floor(Math.log10(x));
  return [1, 2, 2.5, 5, 10].map((m) => m * power).find((m) => m >= x * 0.9999);
}

export class LiveChart {
  constructor(canvas) {
    this.canvas = canvas;
    this.context = canvas.getContext("2d");
    /** key -> { colour, samples: [[time ms, value or null for a break]] } */
    this.series = new Map();
  }

  setSeries(key, colour) {
    this.series.set(key, { colour, samples: [] });
  }

  removeSeries(key) {
    this.series.delete(key);
  }

  push(key, timeMs, value) {
    const line = this.series.get(key);
    if (line && Number.isFinite(value)) {
      line.samples.push([timeMs, value]);
    }
  }

  /** Ends the line here (a reconnect, another algorithm): the next sample starts anew. */
  breakLine(key, timeMs) {
    this.series.get(key)?.samples.push([timeMs, null]);
  }

  draw(now) {
    const { canvas, context: g } = this;
    const ratio = window.devicePixelRatio || 1;
    const width = Math.max(1, Math.round(canvas.clientWidth * ratio));
    const height = Math.max(1, Math.round(canvas.clientHeight * ratio));
    if (canvas.width !== width || canvas.height !== height) {
      canvas.width = width;
      canvas.height = height;
    }
    const style = getComputedStyle(canvas);
    g.setTransform(ratio, 0, 0, ratio, 0, 0);
    const w = width / ratio;
    const h = height / ratio;
    g.clearRect(0, 0, w, h);

    let highest = 0;
    for (const line of this.series.values()) {
      const first = line.samples.findIndex(([t]) => t >= now - WINDOW_MS);
      line.samples.splice(0, first < 0 ? line.samples.length : first);
      for (const [, value] of line.samples) {
        highest = Math.max(highest, value);
      }
    }
    const step = niceStep((highest > 0 ? highest : 0.1) / GRID_STEPS);
    const steps = Math.max(1, Math.ceil(highest / step - 1e-9));
    const top = step * steps;

    const left = 52;
    const right = w - 8;
    const plotTop = 8;
    const bottom = h - 22;
    const x = (t) => right - ((now - t) / WINDOW_MS) * (right - left);
    const y = (v) => bottom - (v / top) * (bottom - plotTop);

    g.font = `12px ${style.fontFamily}`;
    g.fillStyle = style.color;
    g.strokeStyle = style.getPropertyValue("--grid").trim() || "#ccc";
    g.lineWidth = 1;
    g.textAlign = "right";
    g.textBaseline = "middle";
    for (let i = 0; i <= steps; i++) {
      const value = step * i;
      g.beginPath();
      g.moveTo(left, Math.round(y(value)) + 0.5);
      g.lineTo(right, Math.round(y(value)) + 0.5);
      g.stroke();
      g.fillText(String(parseFloat(value.toPrecision(6))), left - 6, y(value));
    }
    g.textBaseline = "top";
    for (const seconds of [10, 5, 0]) {
      g.textAlign = seconds === 10 ? "left" : seconds === 0 ? "right" : "center";
      g.fillText(seconds === 0 ? "now" : `−${seconds} s`, x(now - seconds * 1000), bottom + 6);
    }

    g.lineWidth = 2;
    g.lineJoin = "round";
    for (const line of this.series.values()) {
      g.strokeStyle = line.colour;
      g.beginPath();
      let pen = false;
      for (const [t, value] of line.samples) {
        if (value === null) {
          pen = false;
        } else if (pen) {
          g.lineTo(x(t), y(value));
        } else {
          g.moveTo(x(t), y(value));
          pen = true;
        }
      }
      g.stroke();
    }
  }
}

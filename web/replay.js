// replay.js: the transport bar of a replay (a recording played by the server at the
// viewer's pace, proto/PROTOCOL.md "Recordings and replay"): play and pause, a frame back
// and on, the speed, a loop over one label's frames, a scrubber marked with the labels,
// and the frame shown. It sends controls through `send(message)` (to every view) and shows
// where the server says the replay stands. Keys, on the page: Space plays or pauses, `,`
// and `.` step a frame.

/** The DOM parts of the bar, by id. */
const IDS = {
  bar: "replay-bar",
  play: "replay-play",
  back: "replay-back",
  forward: "replay-forward",
  speed: "replay-speed",
  loop: "replay-loop",
  position: "replay-position",
  marks: "replay-marks",
  frame: "replay-frame",
};

export class ReplayBar {
  /** `send(message)`: sends a replay control to every view. */
  constructor(send) {
    this.send = send;
    this.parts = Object.fromEntries(Object.entries(IDS).map(([k, id]) => [k, document.getElementById(id)]));
    this.recording = null;
    this.state = { frame: 0, playing: true, speed: 1, loop: null };
    const { play, back, forward, speed, loop, position } = this.parts;
    play.addEventListener("click", () => this.togglePlay());
    back.addEventListener("click", () => this.step(-1));
    forward.addEventListener("click", () => this.step(1));
    speed.addEventListener("change", () => this.send({ type: "play", speed: Number(speed.value) }));
    loop.addEventListener("change", () => {
      if (loop.value === "") {
        this.send({ type: "loop" });
      } else {
        const [first, last] = loop.value.split("-").map(Number);
        this.send({ type: "loop", first, last });
      }
    });
    position.addEventListener("input", () => this.send({ type: "seek", frame: Number(position.value) }));
    document.addEventListener("keydown", (event) => this.key(event));
  }

  /** Shows the bar for `recording` (its snapshot's `replay`), or hides it (null). */
  show(recording) {
    const { bar, loop, position, marks } = this.parts;
    bar.hidden = recording === null;
    if (recording === null || recording.name === this.recording?.name) {
      this.recording = recording;
      return;
    }
    this.recording = recording;
    position.max = String(Math.max(0, recording.frames - 1));
    loop.replaceChildren(new Option("nothing", ""));
    marks.replaceChildren();
    const span = Math.max(1, recording.frames - 1);
    for (const [i, { label, first, last }] of recording.labels.entries()) {
      loop.add(new Option(`${label} (frames ${first}-${last})`, `${first}-${last}`));
      const mark = document.createElement("span");
      mark.textContent = label;
      mark.classList.toggle("low", i % 2 === 1); // every other one a row down: they stay apart
      mark.style.left = `${(((first + last) / 2) * 100) / span}%`;
      marks.append(mark);
    }
  }

  /** Where the server says the replay stands (a `replay` message). */
  update({ frame, playing, speed, loop }) {
    this.state = { frame, playing, speed, loop: loop ?? null };
    const { play, speed: speedPicker, loop: loopPicker, position, frame: frameLine } = this.parts;
    play.textContent = playing ? "Pause" : "Play";
    play.setAttribute("aria-pressed", String(playing));
    const value = String(speed);
    if (![...speedPicker.options].some((o) => o.value === value)) {
      speedPicker.add(new Option(`${value}×`, value));
    }
    speedPicker.value = value;
    loopPicker.value = loop ? `${loop[0]}-${loop[1]}` : "";
    if (document.activeElement !== position) {
      position.value = String(frame);
    }
    frameLine.textContent = `frame ${frame}${this.recording ? ` of ${this.recording.frames - 1}` : ""}`;
  }

  togglePlay() {
    this.send(this.state.playing ? { type: "pause" } : { type: "play" });
  }

  step(frames) {
    this.send({ type: "step", frames });
  }

  key(event) {
    if (this.parts.bar.hidden || event.altKey || event.ctrlKey || event.metaKey) {
      return;
    }
    const typing = event.target instanceof HTMLSelectElement || event.target instanceof HTMLInputElement;
    if (event.key === " " && !typing && !(event.target instanceof HTMLButtonElement)) {
      this.togglePlay();
    } else if (event.key === "," && !typing) {
      this.step(-1);
    } else if (event.key === "." && !typing) {
      this.step(1);
    } else {
      return;
    }
    event.preventDefault();
  }
}

// head-group.js: heads drawn together. Every <facewire-head> element (facewire-head.js)
// draws through a group: its own group of one, or one a page makes for several (the
// facewire page's two views side by side). A group has one camera (a drag in any member
// turns them all), at most one sound (sound.js) whose clock they draw by, and one drawing
// loop: once per animation frame each member decodes only its newest frame, and the members
// show the same frame, the newest sequence number every live member has, or, while the
// sound plays, the frame whose `t` is being heard, so two views of one stream stay in step
// and the face is seen when its voice is heard.

import { DrawScale } from "./draw-scale.js";
import { quantile } from "./quantile.js";

/** A member whose last frame is older than this does not hold the others back, ms. */
const STALE_MS = 300;
/** How often the sound's wait for the face is tuned, ms. */
const TUNE_FACE_EVERY_MS = 1000;
/** Lags and chances to draw remembered for the draw target. */
const DRAW_LAGS = 31;

/** Keeps `value` among the last DRAW_LAGS of `list`. */
function remember(list, value) {
  list.push(value);
  if (list.length > DRAW_LAGS) {
    list.shift();
  }
}

export class HeadGroup {
  /**
   * `camera`: the OrbitCamera (camera.js) every member is seen through; `sound`: the Sound
   * whose clock they draw by, or null; `onTick(now)`: called once per animation frame after
   * the members drew (a page's chart and numbers).
   */
  constructor({ camera, sound = null, onTick = () => {} }) {
    this.camera = camera;
    this.sound = sound;
    this.onTick = onTick;
    this.members = [];
    this.decoding = false;
    this.cameraMoved = true;
    this.loop = 0;
    /** Milliseconds from choosing frames to drawing them, the last DRAW_LAGS times. */
    this.lags = [];
    /**
     * Milliseconds between one chance to choose frames and the next (an animation frame
     * with no decode under way), the last DRAW_LAGS times.
     */
    this.intervals = [];
    this.lastChance = null;
    /** The pixels the members are drawn with while their voice plays (draw-scale.js). */
    this.drawScale = new DrawScale();
    this.faceTuned = -Infinity;
    /** The rest mesh the camera was framed on last. */
    this.framed = null;
    camera.onChange(() => {
      this.cameraMoved = true;
    });
  }

  /** Draws `element` with the others from the next animation frame; it leaves its last group. */
  add(element) {
    if (this.members.includes(element)) {
      return;
    }
    element.joinGroup(this);
    this.members.push(element);
    this.cameraMoved = true;
    if (!this.loop) {
      this.loop = requestAnimationFrame((now) => this.animate(now));
    }
  }

  /** Stops drawing `element`; the loop stops with the last member. */
  remove(element) {
    this.members = this.members.filter((m) => m !== element);
    if (this.members.length === 0) {
      cancelAnimationFrame(this.loop);
      this.loop = 0;
    }
  }

  /** Frames the camera on a member's rest mesh (once per mesh: both views show the same). */
  frameMesh(url, mesh, mouth) {
    if (this.framed !== url) {
      this.framed = url;
      this.camera.frame(mesh.positions, mesh.mmPerUnit, mouth);
    }
  }

  /** The sequence number every member draws: the newest that every live member has. */
  commonSeq(now) {
    const fresh = this.members.filter((m) => m.state === "live" && now - m.headView.lastArrival < STALE_MS);
    return fresh.length > 0 ? Math.min(...fresh.map((m) => m.headView.newestSeq())) : Infinity;
  }

  /**
   * What the members draw next: while the sound plays, the newest frame due by the stream
   * time that will be heard when it is drawn (after the usual lag from choosing to
   * drawing) plus half the usual time from one chance to choose to the next. A frame then
   * first shows within half that time of when its sound is heard, early or late alike
   * (half a frame interval instead would put onsets early on a page that draws every
   * display frame, late on one whose draws take longer than a frame). Without sound, the
   * newest frame every member has. `views`: the members' live views (at least one).
   */
  drawTarget(now, views) {
    const heard = this.sound?.heardTime(now + (quantile(this.lags, 0.5) ?? 0)) ?? null;
    if (heard === null) {
      return { seq: this.commonSeq(now) };
    }
    const rate = this.sound.rate;
    const between = quantile(this.intervals, 0.5) ?? (views[0].frameIntervalS() * 1e3) / rate;
    // Wall-clock milliseconds, as stream seconds at the sound's rate (a slowed replay's).
    return { t: heard + (between / 2e3) * rate };
  }

  /** Tells the sound how late `frame`, just drawn, is for its sound, if it plays. */
  drawnWhenHeard(frame) {
    const heardMs = this.sound?.heardAtMsForTime(frame.producerTimeS) ?? null;
    if (heardMs !== null) {
      this.sound.faceShown(performance.now() - heardMs);
    }
  }

  animate(now) {
    this.loop = requestAnimationFrame((next) => this.animate(next));
    const members = this.members.filter((m) => m.headView);
    if (!this.decoding && members.length > 0) {
      const views = members.map((m) => m.headView);
      // Chosen by the time it is, not the animation frame's stamp: a callback may run well
      // after its frame began (a long draw before it), and the frame is shown after it runs.
      const chosenAt = performance.now();
      const target = this.drawTarget(chosenAt, views);
      const work = views.map((view) => view.prepare(target));
      if (this.lastChance !== null) {
        remember(this.intervals, now - this.lastChance);
        this.drawScale.chance(now - this.lastChance, target.t !== undefined);
      }
      this.lastChance = now;
      if (work.some(Boolean)) {
        this.decoding = true;
        Promise.all(work)
          .then((frames) => {
            frames.forEach((frame, i) => {
              // A member that reconnected meanwhile has a new view: the frame is the old one's.
              if (frame && members[i].headView === views[i]) {
                views[i].show(frame);
                members[i].draw(false);
                this.drawnWhenHeard(frame);
              }
            });
            remember(this.lags, performance.now() - chosenAt);
          })
          .finally(() => {
            this.decoding = false;
          });
      }
    }
    for (const member of members) {
      member.headView.renderer.setDrawScale(this.drawScale.scale);
      member.draw(this.cameraMoved);
    }
    this.cameraMoved = false;
    if (this.sound && now - this.faceTuned >= TUNE_FACE_EVERY_MS) {
      this.faceTuned = now;
      this.sound.tuneFace();
    }
    this.onTick(now);
  }
}

// socket-pump.test.mjs: checks socket-pump.js, a viewer socket read off the main thread,
// against a stand-in WebSocket and a stand-in port to the audio thread: text and frames
// handed on in order (frames with their buffer transferred and their arrival time), the
// voice's chunks decoded and sent to the port only once there is one (the page told only
// their size), an unreadable chunk named, the timeline started over at a snapshot, at a
// replay's state (at its speed) and when a live stream's frames go back (not a replay's),
// a port given later starting at the speed of the moment,
// a connection's events ignored once another is opened, and sends only on an open socket.
// Run `node web/socket-pump.test.mjs proto/fixtures/fwf2`; the exit status is the
// verdict. Not served: the page never loads this file.

import { readFileSync } from "node:fs";
import { join } from "node:path";
import { readFrameHeader } from "./decode.js";
import { SocketPump } from "./socket-pump.js";

const failures = [];

function same(actual, expected, path) {
  if (JSON.stringify(actual) !== JSON.stringify(expected)) {
    failures.push(`${path}: ${JSON.stringify(actual)} != ${JSON.stringify(expected)}`);
  }
}

class FakeSocket {
  constructor(url) {
    this.url = url;
    this.readyState = 0;
    this.sent = [];
    this.closed = null;
  }
  send(text) {
    this.sent.push(text);
  }
  close(code, reason) {
    this.closed = { code, reason };
  }
  opened() {
    this.readyState = 1;
    this.onopen?.();
  }
  receive(data) {
    this.onmessage({ data });
  }
}

/** An "FWA1" chunk of 16-bit PCM: t (s), the server's receipt (µs), its rate and samples. */
function pcmChunk(t, receiveUs, sampleRate, samples) {
  const body = 8 + 2 * samples.length;
  const bytes = new ArrayBuffer(4 + 8 + 8 + 1 + 5 + body);
  const view = new DataView(bytes);
  [0x46, 0x57, 0x41, 0x31].forEach((b, i) => view.setUint8(i, b));
  view.setFloat64(4, t, true);
  view.setBigUint64(12, BigInt(receiveUs), true);
  view.setUint8(20, 1); // one section
  view.setUint8(21, 1); // pcm
  view.setUint32(22, body, true);
  view.setUint32(26, sampleRate, true);
  view.setUint32(30, samples.length, true);
  samples.forEach((s, i) => view.setInt16(34 + 2 * i, s, true));
  return bytes;
}

const fixtures = process.argv[2];
const frames = ["ict_folds.0.bin", "ict_folds.1.bin"].map((name) => {
  const file = readFileSync(join(fixtures, name));
  return file.buffer.slice(file.byteOffset, file.byteOffset + file.byteLength);
});
const seqs = frames.map((f) => readFrameHeader(f).seq);
const [older, newer] = seqs[0] < seqs[1] ? frames : [frames[1], frames[0]];

function setUp() {
  const events = [];
  const sockets = [];
  const pump = new SocketPump(
    (event, transfer = []) => events.push({ ...event, transferred: transfer.length }),
    (url) => {
      const socket = new FakeSocket(url);
      sockets.push(socket);
      return socket;
    },
  );
  const sink = { messages: [], postMessage(message) { this.messages.push(message); } };
  return { events, sockets, pump, sink };
}

// Text, frames and audio handed on; the voice to the port once there is one.
{
  const { events, sockets, pump, sink } = setUp();
  pump.handle({ op: "open", id: 1, url: "ws://node/v1/heads/h/streams/s/view" });
  same(sockets.length, 1, "one socket");
  same(sockets[0].binaryType, "arraybuffer", "binary as array buffers");
  pump.handle({ op: "send", id: 1, text: "early" });
  same(sockets[0].sent, [], "nothing sent before the socket opens");
  sockets[0].opened();
  pump.handle({ op: "send", id: 1, text: '{"type":"pause"}' });
  pump.handle({ op: "send", id: 0, text: "an old connection's" });
  same(sockets[0].sent, ['{"type":"pause"}'], "sent on the open socket, for its connection only");
  sockets[0].receive('{"type":"snapshot","head":"h"}');
  sockets[0].receive(older);
  const chunk = pcmChunk(0.5, 1234, 16_000, [16384, -32768, 0]);
  sockets[0].receive(chunk);
  same(events.map((e) => e.kind), ["open", "text", "frame", "audio"], "events in order");
  same(events[1].data, '{"type":"snapshot","head":"h"}', "text as it came");
  same([events[2].id, events[2].transferred, typeof events[2].arrivalUs], [1, 1, "number"], "frame transferred, with its arrival");
  same([events[3].bytes, events[3].codec, events[3].problem], [chunk.byteLength, "pcm", undefined], "audio told by size");
  same(sink.messages, [], "no port: nothing decoded");
  pump.handle({ op: "sink", port: sink });
  sockets[0].receive(pcmChunk(0.52, 5678, 16_000, [16384, -32768, 0]));
  const sent = sink.messages.at(-1);
  same([sent.type, sent.t, sent.sampleRate, sent.serverReceiveUs, sent.codec], ["chunk", 0.52, 16_000, 5678, "pcm"], "chunk to the port");
  same([...sent.floats], [0.5, -1, 0], "samples as floats of full scale");
  sockets[0].receive(Uint8Array.from([0x46, 0x57, 0x41, 0x31, 1, 2]).buffer);
  const problem = events.at(-1);
  same([problem.kind, problem.problem.includes("t_s")], ["audio", true], `an unreadable chunk is named: ${problem.problem}`);
}

// The timeline: snapshot (rate 1), a replay's state (its speed), frames going back.
{
  const { sockets, pump, sink } = setUp();
  pump.handle({ op: "sink", port: sink });
  pump.handle({ op: "open", id: 1, url: "ws://live" });
  sockets[0].receive('{"type":"snapshot","head":"h"}');
  sockets[0].receive(older);
  sockets[0].receive(newer);
  sockets[0].receive(older);
  same(sink.messages, [{ type: "restart", rate: 1 }, { type: "restart", rate: 1 }, { type: "reset" }], "live: the port starts the timeline, so does the snapshot; reset when frames go back");
  sink.messages.length = 0;
  sockets[0].receive('{"type":"snapshot","head":"h","replay":"take1"}');
  sockets[0].receive('{"type":"replay","frame":0,"playing":true,"speed":0.25,"loop":false}');
  sockets[0].receive(newer);
  sockets[0].receive(older);
  same(sink.messages, [{ type: "restart", rate: 1 }, { type: "restart", rate: 0.25 }], "replay: its state restarts at its speed; frames going back do not reset");
  // A port given after the replay's state (the sound turned on later) starts at its speed.
  const late = { messages: [], postMessage(message) { this.messages.push(message); } };
  pump.handle({ op: "sink", port: late });
  same(late.messages, [{ type: "restart", rate: 0.25 }], "a later port starts at the replay's speed");
}

// Another connection: the old socket closed, its events ignored; a close told once.
{
  const { events, sockets, pump } = setUp();
  pump.handle({ op: "open", id: 1, url: "ws://a" });
  pump.handle({ op: "open", id: 2, url: "ws://b" });
  same(sockets[0].closed, { code: 1000, reason: "viewer closed" }, "the old socket closed");
  sockets[0].receive('{"type":"snapshot"}');
  sockets[0].onclose({ code: 1006, reason: "" });
  same(events, [], "the old socket's events ignored");
  sockets[1].onclose({ code: 4404, reason: "no such head" });
  same(events, [{ kind: "close", id: 2, code: 4404, reason: "no such head", transferred: 0 }], "the new one's close told");
  pump.handle({ op: "close", id: 1, code: 1000, reason: "x" });
  same(sockets[1].closed, null, "a close for an old connection does nothing");
}

if (failures.length > 0) {
  console.error(failures.join("\n"));
  process.exit(1);
}
console.log("socket-pump.js: every case holds");

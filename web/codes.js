// codes.js: the server's WebSocket close codes and end reasons, as proto/src/codes.rs
// defines them (a test in src/server/web.rs checks that the two agree).

/** Close code by name. */
export const CLOSE = Object.freeze({
  normal: 1000,
  going_away: 1001,
  invalid_payload: 1007,
  message_too_big: 1009,
  bad_request: 4400,
  unknown_head: 4404,
  idle: 4408,
  producer_busy: 4409,
  head_deleted: 4410,
  registration_failed: 4422,
  cancelled: 4499,
  try_later: 4503,
});

/** Close codes after which reconnecting cannot help. */
export const FINAL_CLOSE_CODES = new Set([CLOSE.bad_request, CLOSE.unknown_head, CLOSE.registration_failed]);

/** What the page says for each end reason. */
export const END_REASONS = Object.freeze({
  producer_ended: "the producer ended the stream",
  batch_finished: "the batch finished",
  producer_disconnected: "the producer disconnected",
  producer_idle: "the producer went idle",
  producer_cancelled: "the producer was cancelled",
  head_deleted: "the head was deleted",
  server_shutdown: "the server is shutting down",
});

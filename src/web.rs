//! The browser client, embedded in the binary so one command serves everything: a small
//! page that shows a registered head talking live (see `web/`).

use axum::http::header;
use axum::response::IntoResponse;
use axum::routing::get;
use axum::Router;

/// `(path, content type, body)` of every embedded file.
const ASSETS: [(&str, &str, &str); 5] = [
    (
        "/app.js",
        "text/javascript; charset=utf-8",
        include_str!("../web/app.js"),
    ),
    (
        "/decode.js",
        "text/javascript; charset=utf-8",
        include_str!("../web/decode.js"),
    ),
    (
        "/render.js",
        "text/javascript; charset=utf-8",
        include_str!("../web/render.js"),
    ),
    (
        "/style.css",
        "text/css; charset=utf-8",
        include_str!("../web/style.css"),
    ),
    ("/", "text/html; charset=utf-8", include_str!("../web/index.html")),
];

pub fn routes<S: Clone + Send + Sync + 'static>() -> Router<S> {
    let mut router = Router::new();
    for (path, content_type, body) in ASSETS {
        router = router.route(
            path,
            get(move || async move {
                (
                    [
                        (header::CONTENT_TYPE, content_type),
                        (header::CACHE_CONTROL, "no-cache"),
                    ],
                    body,
                )
                    .into_response()
            }),
        );
    }
    router
}

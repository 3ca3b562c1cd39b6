// decode.js: written with the web client

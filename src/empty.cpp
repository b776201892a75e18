// Keeps a stage library non-empty while its folder has no sources yet.

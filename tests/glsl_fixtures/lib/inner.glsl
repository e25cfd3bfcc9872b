float inner() { return 1.0; }

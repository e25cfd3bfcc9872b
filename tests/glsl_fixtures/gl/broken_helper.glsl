// a helper with a deliberate syntax error on line 3
float helper()
{ return 1.0 }

"""Loading generated modules, the GPME, statics and integration."""

"""The command line's verbs, one module each: the arguments a verb takes (`add_parser`) and
what it runs, a thin layer over the API. `attenfit.cli` assembles them."""

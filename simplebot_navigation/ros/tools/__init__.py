"""Tools around a run: the recorder, the Foxglove server and bridge, and message conversion to JSON."""

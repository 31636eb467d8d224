"""Starting the suite: the graph description (`graph`: config/graph.yaml + surveillance.yaml), node
processes (`processes`), the demo runner (`demo`), the `evaluate` command and the sample clip
(`sample`). The top layer: it may import simulation, control and evaluation."""

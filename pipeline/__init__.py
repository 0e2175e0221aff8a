"""The Real2Code reconstruction pipeline, one module per stage, each a plain function from
data to data, plus the procedural objects it trains and tests on."""

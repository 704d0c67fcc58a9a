"""The continuous closed loop (plant + G_c(s)) and its unbalance FRFs: the linear model every
analysis, balancer and comparison evaluates."""

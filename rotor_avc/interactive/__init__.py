"""Self-contained interactive HTML pages (plotly.js embedded) and the JSON form of report data,
shared by the comparison's report and the other commands' reports."""

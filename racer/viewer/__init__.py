"""`racer view`: a local web page that shows a training run live (camera streams, status) or from the store."""

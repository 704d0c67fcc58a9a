"""A recorded run compared with the models: reading the bag, the comparison, its report."""

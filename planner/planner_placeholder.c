/* placeholder: replaced by the planner sources */

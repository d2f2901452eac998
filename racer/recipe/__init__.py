"""`racer recipe`: custom files for a fast lap of one track and car, made from the car's racing line there
(`racer.racing_line`): the line's needs (`line_needs`), the actions they call for (`action_space`), the reward that
carries the line (`reward_source`) and the folder (`folder`)."""

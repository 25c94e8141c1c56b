"""Link impairments: the pure timed queue (:mod:`impairment.queue`: what an impairment is and how it
delays and drops frames on the run's clock) and the element process that applies it inside a
link (:mod:`impairment.element`)."""

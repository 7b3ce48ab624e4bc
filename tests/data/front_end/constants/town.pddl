; The dock (a domain constant) and two offices; parcel b1 waits at the dock.
(define (problem town)
  (:domain depot)
  (:objects office1 office2 - place b1 b2 - parcel)
  (:init (robot-at office2) (at b1 dock) (at b2 dock)
         (road dock office1) (road office1 dock) (road office1 office2) (road office2 office1))
  (:goal (at b1 office1))
  (:metric minimize (total-cost)))
